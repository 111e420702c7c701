// `fascia bench gpu`: ms per full implicit step on the CUDA backend at the paper's Table 3 sizes,
// then scaling to millions of samples, with the tangent-product kernel's achieved bandwidth.
#pragma once

#include "commands.hpp"
#include "model/model.hpp"
#include "solve/linear_solver.hpp"

#include <map>
#include <string>
#include <vector>

namespace fascia::app {

struct BenchGpuOptions {
  bool json = false;                 // one JSON object per line on stdout
  bool quick = false;                // Table 3 sizes and the largest scaling case only, fewer repeats
  std::string precision = "both";    // double | single | both
  std::string design = "both";       // fused | paper | both
  std::string linear = "cg";         // cg | pcg | both: the step's linear solve (bench cpu: cg)
  std::string cg_kernel = "persistent";  // persistent | launches | both (fused design)
  std::vector<int> sizes;            // Table 3 sizes to run, empty: all
  bool tangent = false;              // time the tangent product alone at Table 3 sizes too
  long long max_samples = 4200000;   // largest scaling case (8 neighbours), 0: none
  int repeats = 10;
  std::vector<std::string> sample_pass = {"coalesced"};  // fused design's tangent sample passes: coalesced | records | lanes | staged
  // The compared values of DeviceOptions members; empty: the member's default.
  std::vector<int> lanes;            // fused design, records and lanes passes: threads per sample (0: auto)
  int lane_threads = 128;            // fused design: most threads per tangent block
  int block_samples = 128;           // fused design: samples per block
  std::vector<int> record_keep;      // records pass: pairs per lane kept in registers
  std::vector<int> row_frames;       // frames per block of the launched frame-row passes
  std::vector<int> keep;             // coalesced pass: ELL entries per lane held in registers (0: auto)
  std::vector<int> slot_lanes;       // coalesced pass: lanes per slot sum
  std::vector<int> resident = {2};    // coalesced pass: persistent PCG holding its invariants (2: double too)
  // Coalesced pass: the on/off options of cmd_bench_gpu.cpp's switch table (--dense-tangent,
  // --shape-classes, ...), by DeviceOptions member name, each with the values to compare; an
  // option not here keeps its DeviceOptions default.
  std::map<std::string, std::vector<int>> switches;
  int persistent_blocks_per_sm = 4;  // persistent PCG while the model needs at most this many blocks per SM
};

// ms per benchmark step (engine/bench/step_bench.hpp) on the device, for `fascia bench step
// --backend cuda`: precision "double" | "single", design "fused" | "paper".
double time_cuda_step(const Model& model, LinearMethod linear, int cg_iterations, const std::string& precision,
                      const std::string& design, int repeats);
// Whether a CUDA device is usable; its name.
bool cuda_device_available(std::string* name);

// Runs the benchmark; returns a sysexits code (0 ok, 69 no device).
int run_bench_gpu(const BenchGpuOptions& options);

// Registers `gpu` under the `bench` subcommand.
void add_bench_gpu_command(CLI::App& bench, Action& action);

}  // namespace fascia::app
