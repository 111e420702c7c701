// The body of `fascia run`, shared with `fascia bench scenes` so that the benchmark times exactly
// what a user runs: load and build the scene, simulate, write the trajectory and its sidecar.
#pragma once

#include "backend.hpp"
#include "scene_report.hpp"

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <vector>

namespace fascia::app {

struct RunOptions {
  SceneRequest request;  // the scene, its overrides, --max-memory, -o
  BackendOptions backend;
  int threads = -1;
  bool quiet = false;
  bool json = false;
  bool overwrite = false;                     // replace an existing output
  bool resume = false;                        // continue the output's run from its checkpoint
  std::optional<double> max_wall;             // s: stop with a checkpoint after this wall time
  std::optional<int> checkpoint_every;        // steps; overrides output.checkpoint.every
  std::optional<double> checkpoint_interval;  // s; overrides output.checkpoint.interval
  double status_interval = 10.0;
  int max_steps = 0;  // > 0: stop after this many steps (the benchmark's cap); 0: the scene's count
};

// What a run did, for callers that time it.
struct RunFigures {
  int frames = 0, samples = 0, dofs = 0;
  int steps = 0;                    // steps taken
  long newton_iterations = 0;       // summed over the steps
  long cg_iterations = 0;
  double setup_seconds = 0;         // reading, building and discretising the scene
  double step_seconds = 0;          // the steps and their output, wall clock
};

// Runs a scene as `fascia run` does; returns its exit code (commands.hpp). figures: filled when
// not null.
int run_scene(const RunOptions& options, RunFigures* figures = nullptr);

// Adds the options shared by `fascia run` and `fascia sweep --task` (everything but the scene,
// -o and --set) to a subcommand.
void add_run_options(CLI::App& command, RunOptions& options);

}  // namespace fascia::app
