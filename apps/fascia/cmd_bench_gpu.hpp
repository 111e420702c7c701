// `fascia bench gpu`: ms per full implicit step on the CUDA backend at the paper's Table 3 sizes,
// then scaling to millions of samples, with the tangent-product kernel's achieved bandwidth.
#pragma once

#include "commands.hpp"

#include <string>

namespace fascia::app {

struct BenchGpuOptions {
  bool json = false;                 // one JSON object per line on stdout
  bool quick = false;                // Table 3 sizes and the largest scaling case only, fewer repeats
  std::string precision = "both";    // double | single | both
  std::string design = "both";       // fused | paper | both
  long long max_samples = 4200000;   // largest scaling case (8 neighbours)
  int repeats = 10;
};

// Runs the benchmark; returns a sysexits code (0 ok, 69 no device).
int run_bench_gpu(const BenchGpuOptions& options);

// Registers `gpu` under the `bench` subcommand.
void add_bench_gpu_command(CLI::App& bench, Action& action);

}  // namespace fascia::app
