#include "cmd_bench_discretise.hpp"

#include "bench/discretise_bench.hpp"

#include <iostream>
#include <memory>

namespace fascia::app {

void add_bench_discretise(CLI::App& bench, Action& action) {
  auto options = std::make_shared<DiscretiseBenchOptions>();
  auto json = std::make_shared<bool>(false);
  CLI::App* cmd = bench.add_subcommand(
      "discretise", "Time the meshless discretisation (voxelise, frames, samples, volumes, shape functions)");
  cmd->add_option("--samples", options->sample_counts, "Target sample counts (about 10 per frame)")
      ->capture_default_str();
  cmd->add_option("--neighbours", options->neighbours,
                  "Each frame's support is 1.6 times the distance to its k-th nearest frame: k")
      ->capture_default_str();
  cmd->add_option("--seed", options->seed, "Poisson-disk seed")->capture_default_str();
  cmd->add_flag("--json", *json, "One JSON object per line on stdout");
  cmd->callback([options, json, &action] {
    action = [options, json] {
      for (long n : options->sample_counts) write_bench_row(std::cout, bench_discretise_once(n, *options), *json);
      return kOk;
    };
  });
}

}  // namespace fascia::app
