// `fascia bench discretise [--json] [--samples N]... [--shape mls|rbf] [--neighbours K] [--seed S]`
#pragma once

#include <CLI/CLI.hpp>

namespace fascia::cli {

// Adds the `discretise` subcommand to the `bench` command.
void add_bench_discretise(CLI::App& bench);

}  // namespace fascia::cli
