// The parameter registry: every key of the scene language with its type, unit, range, default
// and one-line doc. It drives validation (dsl/validate), defaults, `fascia check`'s resolved scene
// and `fascia schema` (JSON Schema). Adding a parameter here is the only way to add one.
#pragma once

#include "dsl/units.hpp"

#include <optional>
#include <string>
#include <vector>

namespace fascia::dsl {

enum class ParamType {
  object,       // fixed keys (children)
  named_map,    // user-chosen names -> children[0] (materials, objects)
  list,         // list of children[0]
  one_of,       // a map with exactly one key among children (a load, a region)
  number,       // a quantity of `unit` dimension
  integer,
  boolean,
  string,
  enumeration,  // one of `choices`
  vector3,      // three quantities of `unit` dimension: [x, y, z] or "x y z unit"
  vector3_pair, // two vector3 (a box [[lo], [hi]])
  integer_list,
  string_list,
  path,         // a file, relative to the scene file that names it; must exist
};

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::object;
  std::string doc;
  Dimension unit = dim::none;  // number / vector3 / vector3_pair
  std::optional<double> min, max;  // SI; number/integer (and every component of a vector3)
  bool min_exclusive = false, max_exclusive = false;
  std::string default_value;  // YAML text of the default ("" = no default)
  bool required = false;
  std::vector<std::string> choices;  // enumeration
  int length = 0;                    // integer_list / string_list: required length (0 = any)
  std::vector<ParamSpec> children;   // object / one_of fields; named_map / list item

  const ParamSpec* child(const std::string& key) const;
  std::vector<std::string> child_names() const;
  // "pressure (Pa)", "integer", "one of stvk, neo_hookean", ... for messages.
  std::string expected() const;
  // "> 0", "in (-1, 0.5)", "" when unbounded.
  std::string range_text() const;
};

// The root of the scene language.
const ParamSpec& scene_registry();

// Current version of the scene language (the `fascia:` key).
constexpr int kSceneLanguageVersion = 1;

}  // namespace fascia::dsl
