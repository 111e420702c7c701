// A validated scene value: the source tree checked against the registry, numbers converted to
// SI, defaults filled in. Every value keeps its source position (file:line:col).
#pragma once

#include "dsl/diagnostics.hpp"
#include "dsl/registry.hpp"

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace fascia::dsl {

struct Value {
  enum class Kind { number, integer, boolean, string, list, map };

  Kind kind = Kind::map;
  double number = 0;  // SI
  long long integer = 0;
  bool boolean = false;
  std::string text;  // string, enumeration; path: resolved relative to the working directory
  std::vector<Value> items;
  std::vector<std::pair<std::string, Value>> fields;
  Location where;
  Dimension unit = dim::none;  // number, and each component of a vector
  bool defaulted = false;  // filled in from the registry's default

  const Value* find(const std::string& key) const;
  bool has(const std::string& key) const { return find(key) != nullptr; }
  // Accessors for values the validator guarantees (present by default or required). They throw
  // std::logic_error when the key is absent: that is a registry/spec mismatch, not a user error.
  const Value& at(const std::string& key) const;
  double num(const std::string& key) const { return at(key).number; }
  long long integer_at(const std::string& key) const { return at(key).integer; }
  bool flag(const std::string& key) const { return at(key).boolean; }
  const std::string& str(const std::string& key) const { return at(key).text; }
  std::array<double, 3> vec3() const;  // a vector3 value
};

// Checks `node` against `spec`: unknown keys (with did-you-mean), types, units, ranges, missing
// required keys, missing files. All problems go to `diagnostics`; the returned value holds what
// was valid.
struct SourceNode;
Value validate(const SourceNode& node, const ParamSpec& spec, Diagnostics& diagnostics);

// The resolved scene as YAML: every value in SI with its unit ("40000 Pa"), defaults included.
std::string to_yaml(const Value& value);

}  // namespace fascia::dsl
