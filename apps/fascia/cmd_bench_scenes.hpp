// `fascia bench scenes [--backend cpu|cuda] [--json]`: ms per step of every shipped scene end to
// end, through the same code as `fascia run` (run_scene.hpp), output file included.
#pragma once

#include "commands.hpp"

namespace fascia::app {

void add_bench_scenes(CLI::App& bench, Action& action);

}  // namespace fascia::app
