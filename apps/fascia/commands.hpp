// Subcommands of the fascia program. Each registers itself on the CLI11 app and runs through a
// callback that returns the process exit code (sysexits, DESIGN.md).
#pragma once

#include "exit_code.hpp"

#include <CLI/CLI.hpp>

#include <functional>

namespace fascia::app {

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
