// Shared by run and check: load, validate and build a scene, printing every problem on stderr.
#pragma once

#include "dsl/build_scene.hpp"

#include <nlohmann/json.hpp>

#include <memory>
#include <string>
#include <vector>

namespace fascia::app {

struct LoadedScene {
  dsl::SceneSpec spec;
  dsl::BuiltScene built;
};

// Parses and builds; on failure prints the diagnostics (sorted, file:line:col) and sets
// exit_code to the matching sysexits code, returning nullptr.
std::unique_ptr<LoadedScene> load_scene(const std::string& path, const std::vector<std::string>& overrides,
                                        int& exit_code);

nlohmann::json stats_json(const dsl::DiscretisationStats& stats);
// One entry per coupling: kind, object, other, frames, within_m, line, column.
nlohmann::json couplings_json(const std::vector<dsl::CouplingReport>& couplings);
std::string stats_text(const dsl::DiscretisationStats& stats, const LoadedScene& scene);

}  // namespace fascia::app
