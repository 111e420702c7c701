// `fascia bench gpu`: ms per full implicit step on the CUDA backend at the paper's Table 3 sizes,
// then scaling to millions of samples, with the tangent-product kernel's achieved bandwidth.
#pragma once

#include "commands.hpp"
#include "model/model.hpp"
#include "solve/linear_solver.hpp"

#include <string>
#include <vector>

namespace fascia::app {

struct BenchGpuOptions {
  bool json = false;                 // one JSON object per line on stdout
  bool quick = false;                // Table 3 sizes and the largest scaling case only, fewer repeats
  std::string precision = "both";    // double | single | both
  std::string linear = "cg";         // cg | pcg | both: the step's linear solve (bench cpu: cg)
  std::vector<int> sizes;            // Table 3 sizes to run, empty: all
  bool tangent = false;              // time the tangent product alone at Table 3 sizes too
  long long max_samples = 4200000;   // largest scaling case (8 neighbours), 0: none
  int repeats = 10;
};

// ms per benchmark step (engine/bench/step_bench.hpp) on the device, for `fascia bench step
// --backend cuda`: precision "double" | "single".
double time_cuda_step(const Model& model, LinearMethod linear, int cg_iterations, const std::string& precision,
                      int repeats);
// Whether a CUDA device is usable; its name.
bool cuda_device_available(std::string* name);

// Runs the benchmark; returns a sysexits code (0 ok, 69 no device).
int run_bench_gpu(const BenchGpuOptions& options);

// Registers `gpu` under the `bench` subcommand.
void add_bench_gpu_command(CLI::App& bench, Action& action);

}  // namespace fascia::app
