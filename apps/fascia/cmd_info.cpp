// fascia info FILE.h5: summarise a trajectory (steps, times, objects, final energies, solver figures).
#include "commands.hpp"

#include "io/trajectory.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <numeric>

namespace fascia::app {

namespace {

struct InfoOptions {
  std::string file;
  bool json = false;
};

// An observable's value as JSON: an integer where the file stores the observable as integers
// (counts, flags; the reader returns every value as a double).
nlohmann::json observable_json(bool integer, double value) {
  if (integer) return static_cast<long long>(value);
  return value;
}

int info(const InfoOptions& options) {
  std::error_code ec;
  if (!std::filesystem::exists(options.file, ec)) {
    std::cerr << "fascia: error: " << options.file << ": no such file\n";
    return kNoInput;
  }
  try {
    TrajectoryReader reader(options.file);
    const int steps = reader.step_count();
    const std::vector<double> times = reader.times();
    nlohmann::json j;
    j["file"] = options.file;
    j["creator"] = {{"name", reader.creator_name()}, {"version", reader.creator_version()}};
    const std::vector<int> version = reader.h5md_version();
    j["h5md_version"] = version;
    j["steps"] = steps;
    j["first_time"] = times.empty() ? 0.0 : times.front();
    j["last_time"] = times.empty() ? 0.0 : times.back();
    j["scene_file"] = reader.parameter("scene_file");
    j["command_line"] = reader.parameter("command_line");
    nlohmann::json groups = nlohmann::json::array();
    for (const ParticleGroupInfo& g : reader.particle_groups()) {
      nlohmann::json fields = nlohmann::json::array();
      for (const std::string& e : reader.particle_elements(g.name))
        if (e != "position") fields.push_back(e);
      groups.push_back({{"name", g.name}, {"count", g.count}, {"fields", fields}});
    }
    j["particles"] = groups;
    nlohmann::json final_values = nlohmann::json::object();
    nlohmann::json solver = nlohmann::json::object();
    for (const std::string& name : reader.observable_names()) {
      const std::vector<double> v = reader.observable(name);
      if (v.empty()) continue;
      const bool integer = reader.observable_is_integer(name);
      final_values[name] = observable_json(integer, v.back());
      if (name == "newton_iterations" || name == "cg_iterations" || name == "wall_time") {
        solver[name + "_total"] = observable_json(integer, std::accumulate(v.begin(), v.end(), 0.0));
        solver[name + "_max"] = observable_json(integer, *std::max_element(v.begin(), v.end()));
      }
      if (name == "residual") solver["residual_max"] = *std::max_element(v.begin(), v.end());
      if (name == "converged")
        solver["steps_not_converged"] = std::count_if(v.begin(), v.end(), [](double c) { return c == 0; });
    }
    j["final"] = final_values;
    j["solver"] = solver;
    if (options.json) {
      // Names and text from a damaged file may not be UTF-8: replaced (U+FFFD), not refused.
      std::cout << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
      return kOk;
    }
    std::cout << options.file << " (H5MD " << (version.size() == 2 ? std::to_string(version[0]) + "." + std::to_string(version[1]) : "?")
              << ", written by " << reader.creator_name() << " " << reader.creator_version() << ")\n";
    std::cout << "  scene: " << j["scene_file"].get<std::string>() << "\n";
    std::cout << "  command: " << j["command_line"].get<std::string>() << "\n";
    std::cout << "  steps: " << steps;
    if (!times.empty()) std::cout << ", t = " << times.front() << " .. " << times.back() << " s";
    std::cout << "\n  particles:";
    for (const auto& g : groups) {
      std::cout << "\n    " << g["name"].get<std::string>() << " (" << g["count"] << "):";
      for (const auto& f : g["fields"]) std::cout << " " << f.get<std::string>();
    }
    std::cout << "\n  final:";
    for (auto it = final_values.begin(); it != final_values.end(); ++it) std::cout << "\n    " << it.key() << ": " << it.value();
    std::cout << "\n  solver:";
    for (auto it = solver.begin(); it != solver.end(); ++it) std::cout << "\n    " << it.key() << ": " << it.value();
    std::cout << "\n";
    return kOk;
  } catch (const TrajectoryError& e) {
    std::cerr << "fascia: error: " << e.what() << "\n";
    return kDataError;
  }
}

}  // namespace

void register_info(CLI::App& app, Action& action) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* cmd = app.add_subcommand("info", "Summarise a trajectory file written by fascia run");
  cmd->add_option("file", options->file, "HDF5 trajectory")->required();
  cmd->add_flag("--json", options->json, "Print the summary as JSON");
  cmd->callback([&action, options] { action = [options] { return info(*options); }; });
}

}  // namespace fascia::app
