// Stand-alone entry point `fascia_bench_gpu` for `fascia bench gpu` until apps/fascia/main.cpp
// registers add_bench_gpu_command under its `bench` subcommand.
#include "cmd_bench_gpu.hpp"

#include <CLI/CLI.hpp>

int main(int argc, char** argv) {
  CLI::App app{"fascia bench gpu"};
  CLI::App* bench = app.add_subcommand("bench", "benchmarks");
  fascia::app::add_bench_gpu_command(*bench);
  app.require_subcommand(1);
  bench->require_subcommand(1);
  CLI11_PARSE(app, argc, argv);
  return 0;
}
