#include "dsl/schema.hpp"

#include "dsl/registry.hpp"

namespace fascia::dsl {

namespace {

using nlohmann::json;

// A quantity is a bare number (SI) or a string "number unit".
const char* kQuantityPattern = "^\\s*[-+]?([0-9]+\\.?[0-9]*|\\.[0-9]+)([eE][-+]?[0-9]+)?\\s*[A-Za-z\\xB5/*^0-9 .-]*$";

json quantity_schema(const ParamSpec& spec) {
  json number = {{"type", "number"}};
  if (spec.min) number[spec.min_exclusive ? "exclusiveMinimum" : "minimum"] = *spec.min;
  if (spec.max) number[spec.max_exclusive ? "exclusiveMaximum" : "maximum"] = *spec.max;
  if (spec.unit == dim::none) return number;
  return json{{"anyOf", json::array({number, json{{"type", "string"}, {"pattern", kQuantityPattern}}})}};
}

json vector3_schema(const ParamSpec& spec) {
  ParamSpec component = spec;
  component.type = ParamType::number;
  json as_list = {{"type", "array"}, {"items", quantity_schema(component)}, {"minItems", 3}, {"maxItems", 3}};
  // "x y z unit" in one string.
  json as_text = {{"type", "string"}};
  return json{{"anyOf", json::array({as_list, as_text})}};
}

json schema_of(const ParamSpec& spec) {
  json s;
  switch (spec.type) {
    case ParamType::object:
    case ParamType::one_of: {
      s["type"] = "object";
      json properties = json::object();
      json required = json::array();
      for (const ParamSpec& c : spec.children) {
        properties[c.name] = schema_of(c);
        if (c.required) required.push_back(c.name);
      }
      s["properties"] = properties;
      s["additionalProperties"] = false;
      if (spec.type == ParamType::one_of) {
        s["minProperties"] = 1;
        s["maxProperties"] = 1;
      } else if (!required.empty()) {
        s["required"] = required;
      }
      break;
    }
    case ParamType::named_map:
      s["type"] = "object";
      s["additionalProperties"] = schema_of(spec.children[0]);
      break;
    case ParamType::list:
      s["type"] = "array";
      s["items"] = schema_of(spec.children[0]);
      break;
    case ParamType::number: s = quantity_schema(spec); break;
    case ParamType::integer:
      s["type"] = "integer";
      if (spec.min) s[spec.min_exclusive ? "exclusiveMinimum" : "minimum"] = static_cast<long long>(*spec.min);
      if (spec.max) s[spec.max_exclusive ? "exclusiveMaximum" : "maximum"] = static_cast<long long>(*spec.max);
      break;
    case ParamType::boolean: s["type"] = "boolean"; break;
    case ParamType::string:
    case ParamType::path: s["type"] = "string"; break;
    case ParamType::enumeration:
      s["type"] = "string";
      s["enum"] = spec.choices;
      break;
    case ParamType::vector3: s = vector3_schema(spec); break;
    case ParamType::vector3_pair: {
      ParamSpec corner = spec;
      corner.type = ParamType::vector3;
      s = {{"type", "array"}, {"items", vector3_schema(corner)}, {"minItems", 2}, {"maxItems", 2}};
      break;
    }
    case ParamType::integer_list:
    case ParamType::string_list: {
      json item = {{"type", spec.type == ParamType::integer_list ? "integer" : "string"}};
      if (spec.type == ParamType::integer_list && spec.min) item["minimum"] = static_cast<long long>(*spec.min);
      json as_list = {{"type", "array"}, {"items", item}};
      if (spec.length) {
        as_list["minItems"] = spec.length;
        as_list["maxItems"] = spec.length;
      }
      // include/extends also take one path, and lists of any length of integers one integer.
      if (spec.name == "include" || spec.name == "extends")
        s = {{"anyOf", json::array({as_list, json{{"type", "string"}}})}};
      else if (spec.type == ParamType::integer_list && !spec.length)
        s = {{"anyOf", json::array({as_list, item})}};
      else
        s = as_list;
      break;
    }
  }
  std::string description = spec.doc;
  if (spec.unit != dim::none) description += " [" + dimension_name(spec.unit) + ", SI unit " + si_unit(spec.unit) + "]";
  const std::string range = spec.range_text();
  if (!range.empty() && (spec.type == ParamType::number || spec.type == ParamType::integer))
    description += " (" + range + ")";
  if (!spec.default_value.empty()) description += " (default: " + spec.default_value + ")";
  s["description"] = description;
  if (!spec.default_value.empty()) {
    // JSON Schema defaults are JSON values: numbers and booleans when they parse as such.
    try {
      s["default"] = json::parse(spec.default_value);
    } catch (const json::exception&) {
      s["default"] = spec.default_value;
    }
  }
  return s;
}

void markdown_rows(const ParamSpec& spec, const std::string& path, std::string& out) {
  for (const ParamSpec& c : spec.children) {
    std::string p = path;
    if (spec.type == ParamType::named_map) p += ".<name>";
    else if (spec.type == ParamType::list) p += "[]";
    else p += (p.empty() ? "" : ".") + c.name;
    if (spec.type == ParamType::named_map || spec.type == ParamType::list) {
      markdown_rows(c, p, out);
      continue;
    }
    std::string type = c.expected();
    if (c.type == ParamType::object || c.type == ParamType::one_of) type = c.type == ParamType::one_of ? "one of" : "map";
    if (c.type == ParamType::named_map) type = "named map";
    if (c.type == ParamType::list) type = "list";
    std::string unit = si_unit(c.unit);
    out += "| `" + p + "` | " + type + " | " + (unit.empty() ? "" : unit) + " | " + c.range_text() + " | " +
           (c.required ? "**required**" : c.default_value) + " | " + c.doc + " |\n";
    markdown_rows(c, p, out);
  }
}

}  // namespace

std::string registry_markdown() {
  std::string out = "| key | type | SI unit | range | default | meaning |\n| --- | --- | --- | --- | --- | --- |\n";
  markdown_rows(scene_registry(), "", out);
  return out;
}

nlohmann::json scene_json_schema() {
  json s = schema_of(scene_registry());
  s["$schema"] = "http://json-schema.org/draft-07/schema#";
  s["$id"] = "https://fascia.invalid/schema/scene-" + std::to_string(kSceneLanguageVersion) + ".json";
  s["title"] = "fascia scene";
  return s;
}

}  // namespace fascia::dsl
