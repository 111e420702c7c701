// Subcommands of the fascia program. Each registers itself on the CLI11 app and runs through a
// callback that returns the process exit code (sysexits, DESIGN.md).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

namespace fascia::app {

// Exit codes (sysexits.h): the command-line contract of DESIGN.md.
enum ExitCode : int {
  kOk = 0,
  kSolverFailed = 1,
  kUsage = 64,
  kDataError = 65,
  kNoInput = 66,
  kUnavailable = 69,  // a required service is missing: --backend cuda without a usable CUDA device
  kTooLarge = 71,     // refused for size: more memory than --max-memory, more disk than is free, an input over its cap
  kCantCreate = 73,   // the output exists (no --overwrite or --resume) or is one of the run's inputs
  kIoError = 74,
  kStoppedOnSignal = 75,
  kBadScene = 78,
};

// The command that ran sets this; main() returns it.
using Action = std::function<int()>;

void register_run(CLI::App& app, Action& action);
void register_check(CLI::App& app, Action& action);
void register_info(CLI::App& app, Action& action);
void register_schema(CLI::App& app, Action& action);
void register_study(CLI::App& app, Action& action);
void register_bench(CLI::App& app, Action& action);
void register_render(CLI::App& app, Action& action);
void register_sweep(CLI::App& app, Action& action);
void register_collect(CLI::App& app, Action& action);

}  // namespace fascia::app
