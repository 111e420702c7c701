#include "run_files.hpp"

#include "dsl/registry.hpp"

#include <filesystem>
#include <set>

namespace fascia::app {

namespace {

namespace fs = std::filesystem;

// Walks the validated tree alongside its registry entry, collecting path values and the files
// values came from.
void collect(const dsl::Value& value, const dsl::ParamSpec* spec, std::set<std::string>& sources,
             std::vector<std::string>& paths) {
  if (!value.where.file.empty() && value.where.file.rfind("--set", 0) != 0 && !value.defaulted)
    sources.insert(value.where.file);
  if (spec && spec->type == dsl::ParamType::path && value.kind == dsl::Value::Kind::string) {
    paths.push_back(value.text);
    return;
  }
  for (const auto& [key, child] : value.fields) {
    const dsl::ParamSpec* child_spec = nullptr;
    if (spec) {
      if (spec->type == dsl::ParamType::named_map && !spec->children.empty())
        child_spec = &spec->children.front();
      else
        child_spec = spec->child(key);
    }
    collect(child, child_spec, sources, paths);
  }
  for (const dsl::Value& item : value.items) {
    const dsl::ParamSpec* item_spec =
        spec && spec->type == dsl::ParamType::list && !spec->children.empty() ? &spec->children.front() : nullptr;
    collect(item, item_spec, sources, paths);
  }
}

// Two names for one file: the same inode when both exist, else the same normalised path.
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
}

}  // namespace

std::vector<std::string> run_inputs(const dsl::SceneSpec& spec) {
  std::set<std::string> sources;
  std::vector<std::string> paths;
  collect(spec.resolved, &dsl::scene_registry(), sources, paths);
  std::vector<std::string> inputs{spec.file};
  for (const std::string& s : sources) inputs.push_back(s);
  for (const std::string& p : paths) inputs.push_back(p);
  return inputs;
}

std::string output_refusal(const std::vector<std::string>& outputs, const std::vector<std::string>& inputs,
                           ExistingOutput existing) {
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    for (const std::string& input : inputs)
      if (same_file(outputs[i], input))
        return "output " + outputs[i] + " is an input of this run (" + input + "); choose another output file";
    for (std::size_t j = 0; j < i; ++j)
      if (same_file(outputs[i], outputs[j]))
        return "output " + outputs[j] + " and its sidecar " + outputs[i] +
               " would be one file; give the trajectory an .h5 name";
  }
  std::error_code ec;
  if (existing == ExistingOutput::refuse)
    for (const std::string& o : outputs)
      // A directory is no earlier run: the output check reports it as unwritable (exit 74).
      if (fs::exists(o, ec) && !fs::is_directory(o, ec))
        return o + " exists; give --overwrite to replace it, --resume to continue the run it holds, or another -o";
  return "";
}

}  // namespace fascia::app
