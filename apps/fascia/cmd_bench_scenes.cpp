#include "cmd_bench_scenes.hpp"

#include "number_checks.hpp"
#include "run_scene.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace fascia::app {
namespace {

namespace fs = std::filesystem;

struct BenchScenesOptions {
  std::string directory = "scenes";
  BackendOptions backend;
  bool json = false;
  int max_steps = 5;
  bool fine = true;
  std::vector<std::string> only;  // scene names (file stems) to run; empty: all
  int threads = -1;
  std::vector<std::string> overrides;  // --set, for every scene after its resolution's own
};

struct Case {
  std::string scene;                   // path
  std::string resolution;              // "scene" or the overrides' description
  std::vector<std::string> overrides;
};

// The pelvis at finer fasciae, through the same overrides a user would pass to `fascia run`.
// Spacings chosen for about 16 k and 56 k samples (docs/solvers.md).
const std::vector<std::pair<std::string, std::vector<std::string>>>& pelvis_refinements() {
  static const std::vector<std::pair<std::string, std::vector<std::string>>> r = {
      {"16k", {"objects.fasciae.discretisation.meshless.frame_spacing=3mm",
               "objects.fasciae.discretisation.meshless.sample_spacing=1mm"}},
      {"56k", {"objects.fasciae.discretisation.meshless.frame_spacing=2mm",
               "objects.fasciae.discretisation.meshless.sample_spacing=0.65mm"}},
  };
  return r;
}

int run_bench(const BenchScenesOptions& o) {
  // The device once, before any scene: without one nothing is run (exit 69, as fascia run).
  Backend backend;
  if (const int code = resolve_backend("bench scenes", o.backend, backend); code != kOk) return code;
  std::error_code ec;
  if (!fs::is_directory(o.directory, ec)) {
    std::cerr << "fascia bench scenes: error: no scene folder '" << o.directory
              << "' (run from the repository root or pass --scenes-dir)\n";
    return kNoInput;
  }
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(o.directory))
    if (entry.is_regular_file() && entry.path().extension() == ".yaml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  std::vector<Case> cases;
  for (const std::string& f : files) {
    const std::string stem = fs::path(f).stem().string();
    if (!o.only.empty() && std::find(o.only.begin(), o.only.end(), stem) == o.only.end()) continue;
    cases.push_back({f, "scene", {}});
    if (stem == "pelvis" && o.fine)
      for (const auto& [name, overrides] : pelvis_refinements()) cases.push_back({f, name, overrides});
  }
  char pattern[] = "/tmp/fascia-bench-XXXXXX";
  const char* dir = mkdtemp(pattern);
  if (!dir) {
    std::cerr << "fascia bench scenes: error: cannot create a temporary folder\n";
    return kIoError;
  }
  if (!o.json) {
    std::printf("ms per step end to end as `fascia run` (output written to a temporary file), at most %d steps, "
                "backend %s\n",
                o.max_steps, o.backend.backend.c_str());
    std::printf("%-18s %-6s %7s %8s %7s %6s %9s %10s %8s %9s\n", "scene", "res", "frames", "samples", "dofs", "steps",
                "setup s", "ms/step", "newton", "cg/step");
  }
  int worst = kOk;
  for (const Case& c : cases) {
    RunOptions run;
    run.request.path = c.scene;
    run.request.output = (fs::path(dir) / (fs::path(c.scene).stem().string() + "-" + c.resolution + ".h5")).string();
    run.request.overrides = c.overrides;
    run.request.overrides.insert(run.request.overrides.end(), o.overrides.begin(), o.overrides.end());
    run.backend = o.backend;
    run.threads = o.threads;
    run.quiet = true;
    run.max_steps = o.max_steps;
    RunFigures f;
    const int code = run_scene(run, &f);
    fs::remove(run.request.output, ec);
    fs::remove(fs::path(run.request.output).replace_extension(".xmf"), ec);
    const std::string name = fs::path(c.scene).stem().string();
    const double ms = f.steps > 0 ? 1e3 * f.step_seconds / f.steps : 0.0;
    const double newton = f.steps > 0 ? static_cast<double>(f.newton_iterations) / f.steps : 0.0;
    const double cg = f.steps > 0 ? static_cast<double>(f.cg_iterations) / f.steps : 0.0;
    if (code != kOk) worst = code;
    if (o.json) {
      nlohmann::json j = {{"scene", name},         {"resolution", c.resolution}, {"overrides", run.request.overrides},
                          {"backend", o.backend.backend}, {"frames", f.frames}, {"samples", f.samples},
                          {"dofs", f.dofs},        {"steps", f.steps},          {"setup_seconds", f.setup_seconds},
                          {"ms_per_step", ms},     {"newton_per_step", newton}, {"cg_per_step", cg},
                          {"exit_code", code}};
      std::cout << j.dump() << std::endl;
    } else {
      std::printf("%-18s %-6s %7d %8d %7d %6d %9.2f %10.1f %8.1f %9.1f%s\n", name.c_str(), c.resolution.c_str(),
                  f.frames, f.samples, f.dofs, f.steps, f.setup_seconds, ms, newton, cg,
                  code == kOk ? "" : ("  (exit " + std::to_string(code) + ")").c_str());
      std::fflush(stdout);
    }
  }
  fs::remove_all(dir, ec);
  return worst;
}

}  // namespace

void add_bench_scenes(CLI::App& bench, Action& action) {
  auto options = std::make_shared<BenchScenesOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "scenes", "ms per step of every shipped scene end to end, as `fascia run` does it (output included)");
  add_backend_options(*cmd, options->backend);
  cmd->add_flag("--json", options->json, "One JSON object per line on stdout");
  cmd->add_option("--steps", options->max_steps, "Steps per scene (at most the scene's own count)")
      ->check(kPositiveNumber);
  cmd->add_option("--scenes-dir", options->directory, "Folder of the scenes (default: scenes)");
  cmd->add_option("--only", options->only, "Only these scenes (file names without .yaml)");
  cmd->add_flag("!--no-fine", options->fine, "Skip the pelvis at finer resolutions");
  cmd->add_option("--set", options->overrides,
                  "Override a value in every scene: path=value, as fascia run --set (e.g. output.every=10)");
  cmd->add_option("--threads", options->threads, "CPU threads of each scene's step (0 = one per 500 samples and shell triangles, at most the cores; one fewer, left to the rows, where that is every core of several, under 1,000 per core, with a row after each fixed dynamic step; default: each scene's solver.threads)")
      ->check(kNonNegativeNumber);
  cmd->callback([options, &action] { action = [options] { return run_bench(*options); }; });
}

}  // namespace fascia::app
