#include "dsl/value.hpp"

#include "dsl/source_tree.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <limits>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace fascia::dsl {

namespace fs = std::filesystem;

const Value* Value::find(const std::string& key) const {
  for (const auto& [k, v] : fields)
    if (k == key) return &v;
  return nullptr;
}

const Value& Value::at(const std::string& key) const {
  const Value* v = find(key);
  if (!v) throw std::logic_error("scene value '" + key + "' missing after validation");
  return *v;
}

std::array<double, 3> Value::vec3() const {
  std::array<double, 3> out{0, 0, 0};
  for (std::size_t i = 0; i < 3 && i < items.size(); ++i) out[i] = items[i].number;
  return out;
}

namespace {

std::string quantity_text(double v, const Dimension& d) { return format_si(v, d); }

struct Validator {
  Diagnostics& diagnostics;

  bool check_range(const SourceNode& node, const ParamSpec& spec, double v, const std::string& what) {
    const bool low = spec.min && (spec.min_exclusive ? !(v > *spec.min) : !(v >= *spec.min));
    const bool high = spec.max && (spec.max_exclusive ? !(v < *spec.max) : !(v <= *spec.max));
    if (low || high) {
      diagnostics.error(node.where, what + " must be " + spec.range_text() + ", got " + quantity_text(v, spec.unit));
      return false;
    }
    return true;
  }

  bool read_number(const SourceNode& node, const ParamSpec& spec, const std::string& what, double& out) {
    if (!node.is_scalar() || node.text.empty()) {
      diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got " + node.describe());
      return false;
    }
    std::string err;
    std::optional<Quantity> q = parse_quantity(node.text, err);
    if (!q) {
      diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got '" + node.text + "' (" + err + ")");
      return false;
    }
    if (q->dimension != spec.unit && !q->bare) {
      if (spec.unit == dim::none) {
        diagnostics.error(node.where, what + ": expected a dimensionless number, got '" + node.text + "' (a " +
                                          dimension_name(q->dimension) + ")");
      } else {
        diagnostics.error(node.where, what + ": expected a " + dimension_name(spec.unit) + " in " + si_unit(spec.unit) +
                                          " or a compatible unit, got '" + node.text + "' (a " +
                                          dimension_name(q->dimension) + ")");
      }
      return false;
    }
    if (!std::isfinite(q->value)) {
      diagnostics.error(node.where, what + ": '" + node.text + "' is not a finite number in SI units (" +
                                        (spec.unit == dim::none ? std::string("at most about 1.8e308")
                                                                : "at most about 1.8e308 " + si_unit(spec.unit)) +
                                        ")");
      return false;
    }
    out = q->value;
    return check_range(node, spec, out, what);
  }

  bool read_integer(const SourceNode& node, const ParamSpec& spec, const std::string& what, long long& out) {
    if (node.is_scalar() && !node.quoted && !node.text.empty()) {
      char* end = nullptr;
      errno = 0;
      const long long v = std::strtoll(node.text.c_str(), &end, 10);
      if (*end == '\0') {
        // Integers are held in 32 bits unless the registry gives a larger bound (the seed).
        const double limit = std::max(spec.max.value_or(0.0), static_cast<double>(std::numeric_limits<int>::max()));
        if (errno == ERANGE || static_cast<double>(v) > limit || v < std::numeric_limits<int>::min()) {
          diagnostics.error(node.where, what + ": " + node.text + " is out of range (at most " +
                                            std::to_string(static_cast<long long>(limit)) + ")");
          return false;
        }
        out = v;
        return check_range(node, spec, static_cast<double>(v), what);
      }
    }
    diagnostics.error(node.where, what + ": expected an integer, got " + node.describe());
    return false;
  }

  Value scalar_value(const SourceNode& node, const ParamSpec& spec) {
    Value v;
    v.where = node.where;
    v.unit = spec.unit;
    return v;
  }

  std::optional<Value> vector3(const SourceNode& node, const ParamSpec& spec, const std::string& what) {
    std::vector<SourceNode> parts;
    if (node.is_sequence()) {
      parts = node.items;
    } else if (node.is_scalar() && !node.quoted) {
      // "x y z unit": three numbers sharing one trailing unit.
      std::istringstream in(node.text);
      std::vector<std::string> words;
      for (std::string w; in >> w;) words.push_back(w);
      std::string unit;
      if (words.size() == 4) {
        unit = words.back();
        words.pop_back();
      }
      if (words.size() == 3) {
        for (const std::string& w : words) {
          SourceNode part = node;
          part.text = unit.empty() ? w : w + " " + unit;
          parts.push_back(part);
        }
      }
    }
    if (parts.size() != 3) {
      diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got " +
                                        (node.is_sequence() ? "a list of " + std::to_string(node.items.size())
                                                            : node.describe()));
      return std::nullopt;
    }
    Value v = scalar_value(node, spec);
    v.kind = Value::Kind::list;
    bool ok = true;
    ParamSpec component = spec;
    component.type = ParamType::number;
    for (std::size_t i = 0; i < 3; ++i) {
      double x = 0;
      ok = read_number(parts[i], component, what + "[" + std::to_string(i) + "]", x) && ok;
      Value c = scalar_value(parts[i], component);
      c.kind = Value::Kind::number;
      c.number = x;
      v.items.push_back(c);
    }
    if (!ok) return std::nullopt;
    return v;
  }

  std::optional<Value> run(const SourceNode& node, const ParamSpec& spec, const std::string& what) {
    Value v = scalar_value(node, spec);
    switch (spec.type) {
      case ParamType::object:
      case ParamType::one_of: {
        if (!node.is_map()) {
          diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got " + node.describe());
          return std::nullopt;
        }
        v.kind = Value::Kind::map;
        const std::vector<std::string> names = spec.child_names();
        for (std::size_t i = 0; i < node.fields.size(); ++i) {
          const auto& [key, child] = node.fields[i];
          const ParamSpec* child_spec = spec.child(key);
          if (!child_spec) {
            diagnostics.error(node.key_locations[i], "unknown key '" + key + "' in " + what + did_you_mean(key, names) +
                                                         "; expected one of " + [&] {
                                                           std::string s;
                                                           for (std::size_t k = 0; k < names.size(); ++k)
                                                             s += (k ? ", " : "") + names[k];
                                                           return s;
                                                         }());
            continue;
          }
          std::optional<Value> c = run(child, *child_spec, key);
          if (c) v.fields.emplace_back(key, std::move(*c));
        }
        if (spec.type == ParamType::one_of) {
          if (node.fields.size() != 1) {
            diagnostics.error(node.where, what + ": expected exactly one of " + [&] {
              std::string s;
              for (std::size_t k = 0; k < names.size(); ++k) s += (k ? ", " : "") + names[k];
              return s;
            }() + ", got " + std::to_string(node.fields.size()) + " keys");
            return std::nullopt;
          }
          if (v.fields.size() != 1) return std::nullopt;
          return v;
        }
        fill_defaults(v, spec, node.where, what);
        return v;
      }
      case ParamType::named_map: {
        if (node.is_null()) {
          v.kind = Value::Kind::map;
          return v;
        }
        if (!node.is_map()) {
          diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got " + node.describe());
          return std::nullopt;
        }
        v.kind = Value::Kind::map;
        for (const auto& [key, child] : node.fields) {
          std::optional<Value> c = run(child, spec.children[0], what + "." + key);
          if (c) v.fields.emplace_back(key, std::move(*c));
        }
        return v;
      }
      case ParamType::list: {
        if (node.is_null()) {
          v.kind = Value::Kind::list;
          return v;
        }
        if (!node.is_sequence()) {
          diagnostics.error(node.where, what + ": expected a list (write '- ' before each item), got " + node.describe());
          return std::nullopt;
        }
        v.kind = Value::Kind::list;
        for (std::size_t i = 0; i < node.items.size(); ++i) {
          std::optional<Value> c = run(node.items[i], spec.children[0], what + "[" + std::to_string(i) + "]");
          if (c) v.items.push_back(std::move(*c));
        }
        return v;
      }
      case ParamType::number: {
        v.kind = Value::Kind::number;
        if (!read_number(node, spec, what, v.number)) return std::nullopt;
        return v;
      }
      case ParamType::integer: {
        v.kind = Value::Kind::integer;
        if (!read_integer(node, spec, what, v.integer)) return std::nullopt;
        return v;
      }
      case ParamType::boolean: {
        v.kind = Value::Kind::boolean;
        if (node.is_scalar() && !node.quoted) {
          const std::string& t = node.text;
          if (t == "true" || t == "True" || t == "TRUE" || t == "yes" || t == "on") {
            v.boolean = true;
            return v;
          }
          if (t == "false" || t == "False" || t == "FALSE" || t == "no" || t == "off") {
            v.boolean = false;
            return v;
          }
        }
        diagnostics.error(node.where, what + ": expected true or false, got " + node.describe());
        return std::nullopt;
      }
      case ParamType::string:
      case ParamType::path: {
        if (!node.is_scalar() || node.text.empty()) {
          diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got " + node.describe());
          return std::nullopt;
        }
        v.kind = Value::Kind::string;
        v.text = node.text;
        if (spec.type == ParamType::path) {
          fs::path p(node.text);
          if (p.is_relative() && node.where.file != "--set" && !node.where.file.empty())
            p = fs::path(node.where.file).parent_path() / p;
          v.text = p.lexically_normal().string();
          std::error_code ec;
          if (!fs::exists(v.text, ec)) {
            diagnostics.error(node.where, what + ": file '" + v.text + "' not found", ExitCode::missing_input);
            return std::nullopt;
          }
          if (fs::is_directory(v.text, ec) || !std::ifstream(v.text)) {
            diagnostics.error(node.where, what + ": cannot read '" + v.text + "'", ExitCode::missing_input);
            return std::nullopt;
          }
        }
        return v;
      }
      case ParamType::enumeration: {
        if (node.is_scalar()) {
          for (const std::string& c : spec.choices) {
            if (c == node.text) {
              v.kind = Value::Kind::string;
              v.text = node.text;
              return v;
            }
          }
          diagnostics.error(node.where, what + ": '" + node.text + "' is not " + spec.expected() +
                                            did_you_mean(node.text, spec.choices));
          return std::nullopt;
        }
        diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got " + node.describe());
        return std::nullopt;
      }
      case ParamType::vector3: return vector3(node, spec, what);
      case ParamType::vector3_pair: {
        if (!node.is_sequence() || node.items.size() != 2) {
          diagnostics.error(node.where, what + ": expected " + spec.expected() + ", got " +
                                            (node.is_sequence() ? "a list of " + std::to_string(node.items.size())
                                                                : node.describe()));
          return std::nullopt;
        }
        v.kind = Value::Kind::list;
        ParamSpec corner = spec;
        corner.type = ParamType::vector3;
        std::optional<Value> lo = vector3(node.items[0], corner, what + "[0]");
        std::optional<Value> hi = vector3(node.items[1], corner, what + "[1]");
        if (!lo || !hi) return std::nullopt;
        v.items = {*lo, *hi};
        return v;
      }
      case ParamType::integer_list:
      case ParamType::string_list: {
        const bool integers = spec.type == ParamType::integer_list;
        // A single integer where any number of them is allowed is a list of one (label: 3).
        SourceNode one;
        if (integers && !spec.length && node.is_scalar()) {
          one.kind = SourceNode::Kind::sequence;
          one.where = node.where;
          one.items = {node};
        }
        const SourceNode& list = one.is_sequence() ? one : node;
        if (!list.is_sequence() || (spec.length && static_cast<int>(list.items.size()) != spec.length)) {
          diagnostics.error(list.where, what + ": expected " + spec.expected() + ", got " +
                                            (list.is_sequence() ? "a list of " + std::to_string(list.items.size())
                                                                : list.describe()));
          return std::nullopt;
        }
        v.kind = Value::Kind::list;
        bool ok = true;
        for (std::size_t i = 0; i < list.items.size(); ++i) {
          Value item = scalar_value(list.items[i], spec);
          const std::string item_what = what + "[" + std::to_string(i) + "]";
          if (integers) {
            item.kind = Value::Kind::integer;
            ok = read_integer(list.items[i], spec, item_what, item.integer) && ok;
          } else {
            item.kind = Value::Kind::string;
            if (!list.items[i].is_scalar()) {
              diagnostics.error(list.items[i].where, item_what + ": expected a name, got " + list.items[i].describe());
              ok = false;
            }
            item.text = list.items[i].text;
          }
          v.items.push_back(item);
        }
        if (!ok) return std::nullopt;
        return v;
      }
    }
    return std::nullopt;
  }

  static bool has_required(const ParamSpec& spec) {
    for (const ParamSpec& c : spec.children)
      if (c.required) return true;
    return false;
  }

  // Required keys that are missing, defaults for the others; absent sub-objects without required
  // keys are created so that their defaults appear in the resolved scene.
  void fill_defaults(Value& v, const ParamSpec& spec, const Location& where, const std::string& what) {
    for (const ParamSpec& c : spec.children) {
      if (v.has(c.name)) continue;
      if (c.required) {
        // A key that was present but invalid was already reported.
        continue;
      }
      if (!c.default_value.empty()) {
        Diagnostics local;
        SourceNode def = parse_yaml(c.default_value, "<default>", local);
        def.where = where;
        Validator inner{local};
        std::optional<Value> d = inner.run(def, c, c.name);
        if (!d || !local.empty()) throw std::logic_error("invalid registry default for " + c.name);
        d->defaulted = true;
        d->where = where;
        v.fields.emplace_back(c.name, std::move(*d));
      } else if (c.type == ParamType::object && !has_required(c)) {
        SourceNode empty;
        empty.kind = SourceNode::Kind::map;
        empty.where = where;
        std::optional<Value> d = run(empty, c, c.name);
        if (d) {
          d->defaulted = true;
          v.fields.emplace_back(c.name, std::move(*d));
        }
      }
    }
    (void)what;
  }

};

// Required keys are checked on the source tree so that a key that is present but invalid is not
// also reported as missing.
void report_missing(const SourceNode& node, const ParamSpec& spec, const std::string& what, Diagnostics& diagnostics) {
  switch (spec.type) {
    case ParamType::object:
      if (!node.is_map()) return;
      for (const ParamSpec& c : spec.children) {
        const SourceNode* child = node.find(c.name);
        if (!child) {
          // A misspelt key ('yuong') is reported as unknown with a suggestion; not also as missing.
          bool misspelt = false;
          for (const auto& field : node.fields)
            misspelt = misspelt || (!spec.child(field.first) && closest_match(field.first, spec.child_names()) == c.name);
          if (c.required && !misspelt)
            diagnostics.error(node.where, what + ": missing required key '" + c.name + "' (" + c.doc + "; " +
                                              c.expected() + ")");
          continue;
        }
        report_missing(*child, c, c.name, diagnostics);
      }
      return;
    case ParamType::one_of:
      if (!node.is_map()) return;
      for (const auto& [key, child] : node.fields)
        if (const ParamSpec* c = spec.child(key)) report_missing(child, *c, key, diagnostics);
      return;
    case ParamType::named_map:
      if (!node.is_map()) return;
      for (const auto& [key, child] : node.fields) report_missing(child, spec.children[0], what + "." + key, diagnostics);
      return;
    case ParamType::list:
      if (!node.is_sequence()) return;
      for (std::size_t i = 0; i < node.items.size(); ++i)
        report_missing(node.items[i], spec.children[0], what + "[" + std::to_string(i) + "]", diagnostics);
      return;
    default: return;
  }
}

}  // namespace

Value validate(const SourceNode& node, const ParamSpec& spec, Diagnostics& diagnostics) {
  Validator validator{diagnostics};
  SourceNode root = node;
  if (root.is_null()) root.kind = SourceNode::Kind::map;
  report_missing(root, spec, spec.name, diagnostics);
  std::optional<Value> v = validator.run(root, spec, spec.name);
  return v ? *v : Value{};
}

namespace {

void emit(YAML::Emitter& out, const Value& v) {
  switch (v.kind) {
    case Value::Kind::number: out << format_si(v.number, v.unit); break;
    case Value::Kind::integer: out << v.integer; break;
    case Value::Kind::boolean: out << (v.boolean ? "true" : "false"); break;
    case Value::Kind::string: out << v.text; break;
    case Value::Kind::list: {
      bool flat = true;
      for (const Value& i : v.items) flat = flat && i.kind != Value::Kind::map;
      if (flat) out << YAML::Flow;
      out << YAML::BeginSeq;
      for (const Value& i : v.items) emit(out, i);
      out << YAML::EndSeq;
      break;
    }
    case Value::Kind::map:
      out << YAML::BeginMap;
      for (const auto& [key, value] : v.fields) {
        out << YAML::Key << key << YAML::Value;
        emit(out, value);
      }
      out << YAML::EndMap;
      break;
  }
}

}  // namespace

std::string to_yaml(const Value& value) {
  YAML::Emitter out;
  emit(out, value);
  return std::string(out.c_str()) + "\n";
}

}  // namespace fascia::dsl
