// Standalone driver for `bench discretise` until apps/fascia/main.cpp registers it under
// `fascia bench` (then this file and its target go).
#include "cmd_bench_discretise.hpp"

int main(int argc, char** argv) {
  CLI::App app{"fascia discretisation benchmark"};
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks");
  bench->require_subcommand(1);
  fascia::cli::add_bench_discretise(*bench);
  app.require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
