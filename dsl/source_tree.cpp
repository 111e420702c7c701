#include "dsl/source_tree.hpp"

#include "dsl/registry.hpp"

#include <yaml-cpp/eventhandler.h>
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
    case Kind::scalar:
      // Long texts (a file that is not a scene, a pasted blob) are named, not echoed.
      if (text.size() > 60) return "a text of " + std::to_string(text.size()) + " characters ('" + text.substr(0, 40) + "...')";
      return "'" + text + "'";
  }
  return "?";
}

namespace {

Location location_of(const YAML::Mark& mark, const std::string& file, int line_offset = 0, int column_offset = 0) {
  if (mark.line < 0) return {file, 1, 1};  // yaml-cpp has no position (end of input): the file
  return {file, mark.line + 1 + line_offset, mark.column + 1 + column_offset};
}

struct Converter {
  std::string file;
  Diagnostics& diagnostics;
  int line_offset = 0;
  int column_offset = 0;
  std::size_t values = 0;  // nodes converted so far, aliases counted at every use
  bool too_many = false;
  int depth = 0;  // lists and maps open around the node being converted
  bool too_deep = false;

  Location at(const YAML::Mark& mark) const { return location_of(mark, file, line_offset, column_offset); }

  SourceNode convert(const YAML::Node& node, const Location& fallback) {
    SourceNode out;
    out.where = node.Mark().line >= 0 ? at(node.Mark()) : fallback;
    if (too_many) return out;
    if (++values > kMaxSceneValues) {
      // Aliases (*name) copy their anchor's whole value: a few lines can stand for billions.
      too_many = true;
      diagnostics.error(out.where, "the scene expands to more than " + std::to_string(kMaxSceneValues) +
                                       " values here (YAML aliases '*name' repeating large anchors?)",
                        ExitCode::too_large);
      return out;
    }
    if ((node.IsSequence() || node.IsMap()) && depth >= kMaxSceneDepth) {
      if (!too_deep)
        diagnostics.error(out.where, "lists and maps nest more than " + std::to_string(kMaxSceneDepth) +
                                         " levels deep here (a YAML alias '*name' inside its own anchor?)");
      too_deep = true;
      return out;
    }
    struct Level {
      int& depth;
      explicit Level(int& d) : depth(++d) {}
      ~Level() { --depth; }
    } level(depth);
    switch (node.Type()) {
      case YAML::NodeType::Undefined:
      case YAML::NodeType::Null:
        out.kind = SourceNode::Kind::null;
        // yaml-cpp puts an empty value at the next token; its key is the better position.
        out.where = fallback;
        break;
      case YAML::NodeType::Scalar:
        out.kind = SourceNode::Kind::scalar;
        out.quoted = node.Tag() == "!";
        if (node.Scalar().size() > kMaxValueLength) {
          diagnostics.error(out.where, "a value of " + std::to_string(node.Scalar().size()) +
                                           " characters; scene values are at most " +
                                           std::to_string(kMaxValueLength) + " (is this a scene file?)",
                            ExitCode::too_large);
          out.kind = SourceNode::Kind::null;
          break;
        }
        out.text = node.Scalar();
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
          if (it->first.Scalar().size() > kMaxValueLength) {
            diagnostics.error(key_at, "a key of " + std::to_string(it->first.Scalar().size()) +
                                          " characters; scene keys are at most " + std::to_string(kMaxValueLength),
                              ExitCode::too_large);
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

namespace {

// Sees a document's parse events without building nodes: whether it holds a value, and where
// that starts. (yaml-cpp 0.7's YAML::LoadAll builds nodes without end, until memory runs out,
// for a document that starts with ','; its event parser stops there.)
class DocumentProbe : public YAML::EventHandler {
 public:
  bool content = false;    // the document holds a value (not only a null)
  YAML::Mark first_value;  // where it starts

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { value(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override {
    value(mark);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    value(mark);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    value(mark);
  }
  void OnMapEnd() override {}

 private:
  void value(const YAML::Mark& mark) {
    if (!content) first_value = mark;
    content = true;
  }
};

// Position of the first character that is not blank, a comment or a document marker; line 0
// when there is none.
Location first_text(const std::string& text, const std::string& file) {
  std::istringstream in(text);
  int line = 0;
  for (std::string l; std::getline(in, l);) {
    ++line;
    const std::size_t at = l.find_first_not_of(" \t\r");
    if (at == std::string::npos || l[at] == '#' || l[at] == '%' || l.compare(at, 3, "---") == 0 ||
        l.compare(at, 3, "...") == 0)
      continue;
    return {file, line, static_cast<int>(at) + 1};
  }
  return {file, 0, 0};
}

}  // namespace

SourceNode parse_yaml(const std::string& text, const std::string& file, Diagnostics& diagnostics) {
  YAML::Node node;
  try {
    // The documents' structure first, as events; then the first document as nodes.
    std::istringstream in(text);
    YAML::Parser parser(in);
    DocumentProbe first;
    parser.HandleNextDocument(first);
    const Location text_at = first_text(text, file);
    if (!first.content && text_at.line > 0) {
      // yaml-cpp reads nothing from a document that starts with ',' and drops the rest.
      diagnostics.error(text_at, "YAML syntax error: no value could be read from here on (a ',' outside [ ] or { }?)");
      return {};
    }
    DocumentProbe second;
    if (parser.HandleNextDocument(second) && second.content) {
      // Only one would be used: say so rather than drop the others silently.
      diagnostics.error(location_of(second.first_value, file),
                        "a second YAML document ('---'): a scene is one document; merge them or use 'include:'");
      return {};
    }
    node = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    diagnostics.error(location_of(e.mark, file), "YAML syntax error: " + e.msg);
    return {};
  } catch (const YAML::Exception& e) {
    diagnostics.error(location_of(e.mark, file), std::string("YAML error: ") + e.msg);
    return {};
  }
  Converter converter{file, diagnostics};
  SourceNode tree = converter.convert(node, Location{file, 1, 1});
  if (converter.too_many) return {};
  return tree;
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

enum class ReadResult { ok, unreadable, too_large };

// Reads at most kMaxSceneBytes (devices such as /dev/zero and pipes included: they are read, not
// sized, so the cap is on what was read).
ReadResult read_file(const std::string& path, std::string& text) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return ReadResult::unreadable;
  text.resize(kMaxSceneBytes + 1);
  in.read(&text[0], static_cast<std::streamsize>(text.size()));
  if (in.bad()) return ReadResult::unreadable;
  text.resize(static_cast<std::size_t>(in.gcount()));
  return text.size() > kMaxSceneBytes ? ReadResult::too_large : ReadResult::ok;
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
  const ReadResult read = fs::is_directory(path, ec) ? ReadResult::unreadable : read_file(path, text);
  if (read == ReadResult::unreadable) {
    diagnostics.error(included_from, "cannot read scene file '" + path + "'", ExitCode::missing_input);
    return {};
  }
  if (read == ReadResult::too_large) {
    diagnostics.error(included_from, "scene file '" + path + "' is larger than " +
                                         std::to_string(kMaxSceneBytes >> 20) + " MiB: not a scene?",
                      ExitCode::too_large);
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
  // The registry entry of `node`, followed along the path (nullptr past unknown keys, which
  // validation reports with a suggestion).
  const ParamSpec* spec = &scene_registry();
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
      spec = spec && spec->type == ParamType::list ? &spec->children[0] : nullptr;
    } else {
      if (!node->is_map()) {
        // Overriding inside a scalar: replace it by a map.
        node->kind = SourceNode::Kind::map;
        node->text.clear();
      }
      SourceNode* child = node->find(segment);
      if (spec && spec->type == ParamType::named_map && !child && !last) {
        // A field of an entry the scene does not define: a misspelt name would otherwise create
        // a new, unused entry and leave the intended one unchanged.
        std::vector<std::string> names;
        for (const auto& field : node->fields) names.push_back(field.first);
        const std::string prefix = path.substr(0, start);
        const std::string rest = path.substr(dot);
        std::string message = "no entry '" + segment + "' in " + spec->name + " of the scene";
        const std::string closest = closest_match(segment, names);
        if (!closest.empty()) message += " (did you mean '" + prefix + closest + rest + "'?)";
        if (names.empty()) {
          message += "; the scene defines no " + spec->name;
        } else {
          message += "; it has";
          for (std::size_t i = 0; i < names.size(); ++i) message += (i ? ", '" : " '") + names[i] + "'";
        }
        diagnostics.error(seg_at, message);
        return;
      }
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
      if (spec && (spec->type == ParamType::object || spec->type == ParamType::one_of))
        spec = spec->child(segment);
      else if (spec && spec->type == ParamType::named_map)
        spec = &spec->children[0];
      else
        spec = nullptr;
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
