// Shared by run and check: load, validate and build a scene, printing every problem on stderr.
#pragma once

#include "dsl/build_scene.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace fascia::app {

struct LoadedScene {
  dsl::SceneSpec spec;
  dsl::BuiltScene built;
};

// What run and check share beyond the scene: its overrides, the memory limit, the output.
struct SceneRequest {
  std::string path;
  std::vector<std::string> overrides;
  std::string max_memory;  // --max-memory text ("" = the machine's memory)
  std::string output;      // -o ("" = the scene's output.file)
};

// --set and --max-memory, as run and check take them.
void add_scene_options(CLI::App& command, SceneRequest& request);

// Parses, checks the output path, builds, checks the output's room on disk; on failure prints
// the diagnostics (sorted, file:line:col) and sets exit_code to the matching sysexits code,
// returning nullptr. `before_build` (may be empty) sees the parsed scene before it is
// discretised: a nonzero code it returns (having printed why) ends the load with that code.
std::unique_ptr<LoadedScene> load_scene(const SceneRequest& request, int& exit_code,
                                        const std::function<int(const dsl::SceneSpec&)>& before_build = {});

// The output file of a loaded scene: -o, else the scene's output.file.
std::string output_path(const SceneRequest& request, const dsl::SceneSpec& spec);

nlohmann::json stats_json(const dsl::DiscretisationStats& stats);
// One entry per coupling: kind, object, other, frames, within_m, line, column.
nlohmann::json couplings_json(const std::vector<dsl::CouplingReport>& couplings);
std::string stats_text(const dsl::DiscretisationStats& stats, const LoadedScene& scene);

}  // namespace fascia::app
