// The scene text as a tree that remembers where every key and value came from (file:line:col),
// across included files and command-line overrides. yaml-cpp parses; this layer adds what it
// lacks: duplicate-key detection, file names in positions, include/extends, --set overrides.
#pragma once

#include "dsl/diagnostics.hpp"

#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace fascia::dsl {

// Bounds on what a scene text may ask of the parser (ExitCode::too_large beyond them): the
// scene file's size, the number of values after YAML aliases are expanded, one value's length.
constexpr std::size_t kMaxSceneBytes = std::size_t(4) << 20;
constexpr std::size_t kMaxSceneValues = 200000;
constexpr std::size_t kMaxValueLength = 4096;
// Nesting of lists and maps (a bad scene beyond it): the deepest scene value is a few levels
// down; an alias inside its own anchor ('a: &a [*a]') nests without end, and the conversion
// recurses once per level.
constexpr int kMaxSceneDepth = 64;

struct SourceNode {
  enum class Kind { null, scalar, sequence, map };

  Kind kind = Kind::null;
  std::string text;     // scalar text (unquoted)
  bool quoted = false;  // the scalar was written in quotes (a string, never a number)
  Location where;       // position of the value
  std::vector<SourceNode> items;                       // sequence
  std::vector<std::pair<std::string, SourceNode>> fields;  // map, in source order
  std::vector<Location> key_locations;                 // map: position of each key

  bool is_map() const { return kind == Kind::map; }
  bool is_sequence() const { return kind == Kind::sequence; }
  bool is_scalar() const { return kind == Kind::scalar; }
  bool is_null() const { return kind == Kind::null; }

  // Map lookup; nullptr when absent or not a map.
  const SourceNode* find(const std::string& key) const;
  SourceNode* find(const std::string& key);
  // Index of a key in fields, or -1.
  int index_of(const std::string& key) const;
  // Inserts or replaces a field.
  SourceNode& set(const std::string& key, SourceNode value, const Location& key_location);

  // Short description for messages: "a map", "a list", "'abc'", "nothing".
  std::string describe() const;
};

// Parses YAML text. Syntax errors and duplicate keys go to `diagnostics`; the returned tree holds
// what could be read (the first of duplicated keys wins).
SourceNode parse_yaml(const std::string& text, const std::string& file, Diagnostics& diagnostics);

// Reads and parses a scene file, then resolves `include:` / `extends:` (a path or a list of
// paths relative to the including file): the included scenes are merged first, in order, and the
// including scene on top (maps merge key by key, other values replace). Missing files are
// reported with ExitCode::missing_input at the include's position (or at line 0 for the top file).
SourceNode load_scene_tree(const std::string& path, Diagnostics& diagnostics);

// Applies one `--set path=value` override (the k-th, 1-based) to the tree: path segments are
// separated by '.', list items are addressed by index; missing maps on the path are created. The
// value is parsed as YAML. Errors are reported at "--set:k:col".
void apply_override(SourceNode& root, const std::string& assignment, int k, Diagnostics& diagnostics);

// Deep merge: `top` over `base`.
SourceNode merge_trees(const SourceNode& base, const SourceNode& top);

// Emits the tree as YAML text (block style), for /parameters and `fascia check`.
std::string to_yaml(const SourceNode& node);

}  // namespace fascia::dsl
