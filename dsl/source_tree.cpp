#include "dsl/source_tree.hpp"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace fascia::dsl {

namespace fs = std::filesystem;

const SourceNode* SourceNode::find(const std::string& key) const {
  const int i = index_of(key);
  return i < 0 ? nullptr : &fields[static_cast<std::size_t>(i)].second;
}

SourceNode* SourceNode::find(const std::string& key) {
  const int i = index_of(key);
  return i < 0 ? nullptr : &fields[static_cast<std::size_t>(i)].second;
}

int SourceNode::index_of(const std::string& key) const {
  if (kind != Kind::map) return -1;
  for (std::size_t i = 0; i < fields.size(); ++i)
    if (fields[i].first == key) return static_cast<int>(i);
  return -1;
}

SourceNode& SourceNode::set(const std::string& key, SourceNode value, const Location& key_location) {
  if (kind != Kind::map) {
    kind = Kind::map;
    fields.clear();
    key_locations.clear();
    items.clear();
    text.clear();
  }
  const int i = index_of(key);
  if (i >= 0) {
    fields[static_cast<std::size_t>(i)].second = std::move(value);
    key_locations[static_cast<std::size_t>(i)] = key_location;
    return fields[static_cast<std::size_t>(i)].second;
  }
  fields.emplace_back(key, std::move(value));
  key_locations.push_back(key_location);
  return fields.back().second;
}

std::string SourceNode::describe() const {
  switch (kind) {
    case Kind::null: return "nothing";
    case Kind::map: return "a map";
    case Kind::sequence: return "a list";
    case Kind::scalar: return "'" + text + "'";
  }
  return "?";
}

namespace {

Location location_of(const YAML::Mark& mark, const std::string& file, int line_offset = 0, int column_offset = 0) {
  if (mark.line < 0) return {file, 0, 0};
  return {file, mark.line + 1 + line_offset, mark.column + 1 + column_offset};
}

struct Converter {
  std::string file;
  Diagnostics& diagnostics;
  int line_offset = 0;
  int column_offset = 0;

  Location at(const YAML::Mark& mark) const { return location_of(mark, file, line_offset, column_offset); }

  SourceNode convert(const YAML::Node& node, const Location& fallback) {
    SourceNode out;
    out.where = node.Mark().line >= 0 ? at(node.Mark()) : fallback;
    switch (node.Type()) {
      case YAML::NodeType::Undefined:
      case YAML::NodeType::Null:
        out.kind = SourceNode::Kind::null;
        // yaml-cpp puts an empty value at the next token; its key is the better position.
        out.where = fallback;
        break;
      case YAML::NodeType::Scalar:
        out.kind = SourceNode::Kind::scalar;
        out.text = node.Scalar();
        out.quoted = node.Tag() == "!";
        break;
      case YAML::NodeType::Sequence:
        out.kind = SourceNode::Kind::sequence;
        for (const YAML::Node& item : node) out.items.push_back(convert(item, out.where));
        break;
      case YAML::NodeType::Map: {
        out.kind = SourceNode::Kind::map;
        for (auto it = node.begin(); it != node.end(); ++it) {
          const Location key_at = at(it->first.Mark());
          if (!it->first.IsScalar()) {
            diagnostics.error(key_at, "keys must be plain names, not lists or maps");
            continue;
          }
          const std::string key = it->first.Scalar();
          const int previous = out.index_of(key);
          if (previous >= 0) {
            diagnostics.error(key_at, "duplicate key '" + key + "' (first defined at " +
                                          out.key_locations[static_cast<std::size_t>(previous)].str() + ")");
            continue;
          }
          out.fields.emplace_back(key, convert(it->second, key_at));
          out.key_locations.push_back(key_at);
        }
        break;
      }
    }
    return out;
  }
};

}  // namespace

SourceNode parse_yaml(const std::string& text, const std::string& file, Diagnostics& diagnostics) {
  YAML::Node node;
  try {
    node = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    diagnostics.error(location_of(e.mark, file), "YAML syntax error: " + e.msg);
    return {};
  } catch (const YAML::Exception& e) {
    diagnostics.error(location_of(e.mark, file), std::string("YAML error: ") + e.msg);
    return {};
  }
  Converter converter{file, diagnostics};
  return converter.convert(node, Location{file, 1, 1});
}

SourceNode merge_trees(const SourceNode& base, const SourceNode& top) {
  if (!base.is_map() || !top.is_map()) return top;
  SourceNode out = base;
  out.where = top.where;
  for (std::size_t i = 0; i < top.fields.size(); ++i) {
    const auto& [key, value] = top.fields[i];
    const SourceNode* existing = out.find(key);
    if (existing) {
      out.set(key, merge_trees(*existing, value), top.key_locations[i]);
    } else {
      out.set(key, value, top.key_locations[i]);
    }
  }
  return out;
}

namespace {

bool read_file(const std::string& path, std::string& text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream ss;
  ss << in.rdbuf();
  text = ss.str();
  return !in.bad();
}

SourceNode load_recursive(const std::string& path, const Location& included_from, Diagnostics& diagnostics,
                          std::vector<std::string>& stack) {
  std::error_code ec;
  const std::string canonical = fs::weakly_canonical(path, ec).string();
  for (const std::string& s : stack) {
    if (s == canonical) {
      diagnostics.error(included_from, "scene '" + path + "' includes itself");
      return {};
    }
  }
  std::string text;
  if (fs::is_directory(path, ec) || !read_file(path, text)) {
    diagnostics.error(included_from, "cannot read scene file '" + path + "'", ExitCode::missing_input);
    return {};
  }
  SourceNode tree = parse_yaml(text, path, diagnostics);
  if (tree.is_null()) {
    tree.kind = SourceNode::Kind::map;
    tree.where = {path, 1, 1};
  }
  if (!tree.is_map()) {
    diagnostics.error(tree.where, "a scene must be a map of sections (materials, objects, ...), got " +
                                      tree.describe());
    return {};
  }
  SourceNode merged;
  merged.kind = SourceNode::Kind::map;
  merged.where = tree.where;
  stack.push_back(canonical);
  for (const char* key : {"include", "extends"}) {
    const int index = tree.index_of(key);
    if (index < 0) continue;
    const SourceNode& value = tree.fields[static_cast<std::size_t>(index)].second;
    std::vector<const SourceNode*> paths;
    if (value.is_scalar()) {
      paths.push_back(&value);
    } else if (value.is_sequence()) {
      for (const SourceNode& item : value.items) paths.push_back(&item);
    } else {
      diagnostics.error(value.where, std::string("'") + key + "' expects a scene path or a list of paths, got " +
                                         value.describe());
    }
    for (const SourceNode* p : paths) {
      if (!p->is_scalar()) {
        diagnostics.error(p->where, std::string("'") + key + "' expects scene paths, got " + p->describe());
        continue;
      }
      const fs::path target = fs::path(path).parent_path() / p->text;
      SourceNode included = load_recursive(target.lexically_normal().string(), p->where, diagnostics, stack);
      if (included.is_map()) merged = merge_trees(merged, included);
    }
  }
  stack.pop_back();
  SourceNode own = tree;
  for (const char* key : {"include", "extends"}) {
    const int index = own.index_of(key);
    if (index < 0) continue;
    own.fields.erase(own.fields.begin() + index);
    own.key_locations.erase(own.key_locations.begin() + index);
  }
  return merge_trees(merged, own);
}

}  // namespace

SourceNode load_scene_tree(const std::string& path, Diagnostics& diagnostics) {
  std::vector<std::string> stack;
  return load_recursive(path, Location{path, 0, 0}, diagnostics, stack);
}

void apply_override(SourceNode& root, const std::string& assignment, int k, Diagnostics& diagnostics) {
  const std::string file = "--set";
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) {
    diagnostics.error({file, k, 1}, "expected path=value, got '" + assignment + "'");
    return;
  }
  const std::string path = assignment.substr(0, eq);
  const std::string value_text = assignment.substr(eq + 1);

  // Parse the value as YAML on its own; positions shifted to the value's column in the argument.
  YAML::Node parsed;
  SourceNode value;
  try {
    parsed = YAML::Load(value_text);
    Converter converter{file, diagnostics, k - 1, static_cast<int>(eq + 1)};
    value = converter.convert(parsed, Location{file, k, static_cast<int>(eq + 2)});
  } catch (const YAML::Exception& e) {
    diagnostics.error({file, k, static_cast<int>(eq + 2) + std::max(0, e.mark.column)},
                      "YAML syntax error in value: " + e.msg);
    return;
  }
  value.where = {file, k, static_cast<int>(eq + 2)};
  if (parsed.IsNull() && value_text.empty()) value.kind = SourceNode::Kind::null;

  SourceNode* node = &root;
  if (!node->is_map()) node->kind = SourceNode::Kind::map;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    const std::string segment = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    const Location seg_at{file, k, static_cast<int>(start + 1)};
    if (segment.empty()) {
      diagnostics.error(seg_at, "empty path segment in '" + path + "'");
      return;
    }
    const bool last = dot == std::string::npos;
    if (node->is_sequence()) {
      char* end = nullptr;
      const long index = std::strtol(segment.c_str(), &end, 10);
      if (*end != '\0' || index < 0 || index >= static_cast<long>(node->items.size())) {
        diagnostics.error(seg_at, "'" + segment + "' is not an index of this list (it has " +
                                      std::to_string(node->items.size()) + " items)");
        return;
      }
      SourceNode& item = node->items[static_cast<std::size_t>(index)];
      if (last) {
        item = value;
        return;
      }
      node = &item;
    } else {
      if (!node->is_map()) {
        // Overriding inside a scalar: replace it by a map.
        node->kind = SourceNode::Kind::map;
        node->text.clear();
      }
      SourceNode* child = node->find(segment);
      if (last) {
        node->set(segment, value, seg_at);
        return;
      }
      if (!child) {
        SourceNode empty;
        empty.kind = SourceNode::Kind::map;
        empty.where = seg_at;
        child = &node->set(segment, empty, seg_at);
      }
      node = child;
    }
    start = dot + 1;
  }
}

namespace {

void emit(YAML::Emitter& out, const SourceNode& node) {
  switch (node.kind) {
    case SourceNode::Kind::null: out << YAML::Null; break;
    case SourceNode::Kind::scalar:
      if (node.quoted) out << YAML::DoubleQuoted;
      out << node.text;
      break;
    case SourceNode::Kind::sequence: {
      bool flat = true;
      for (const SourceNode& i : node.items) flat = flat && i.is_scalar();
      if (flat) out << YAML::Flow;
      out << YAML::BeginSeq;
      for (const SourceNode& i : node.items) emit(out, i);
      out << YAML::EndSeq;
      break;
    }
    case SourceNode::Kind::map:
      out << YAML::BeginMap;
      for (const auto& [key, value] : node.fields) {
        out << YAML::Key << key << YAML::Value;
        emit(out, value);
      }
      out << YAML::EndMap;
      break;
  }
}

}  // namespace

std::string to_yaml(const SourceNode& node) {
  YAML::Emitter out;
  emit(out, node);
  return std::string(out.c_str()) + "\n";
}

}  // namespace fascia::dsl
