// `fascia bench discretise [--json] [--samples N]... [--neighbours K] [--seed S]`
#pragma once

#include "commands.hpp"

namespace fascia::app {

// Adds the `discretise` subcommand to the `bench` command.
void add_bench_discretise(CLI::App& bench, Action& action);

}  // namespace fascia::app
