// `fascia bench cpu` and `fascia bench step --backend cpu|cuda`: ms per full implicit step at the
// paper's Table 3 sizes, the step of engine/bench/step_bench.hpp on either backend.
#include "commands.hpp"

#include "bench/step_bench.hpp"
#include "cmd_bench_discretise.hpp"
#include "cmd_bench_scenes.hpp"
#include "number_checks.hpp"
#if FASCIA_WITH_CUDA
#include "cmd_bench_gpu.hpp"
#endif

#include <nlohmann/json.hpp>
#include <omp.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>

namespace fascia::app {
namespace {

struct BenchOptions {
  bool json = false;
  int cg_iterations = 60;
  double min_seconds = 0.5;
  std::vector<int> sizes;
  std::string linear = "cg";
  std::string backend = "cpu";
  std::string precision = "double";  // cuda only
  int repeats = 10;                  // cuda only
};

int run_cpu(const BenchOptions& o);

// One row per Table 3 size on the chosen backend, the same step on both (step_bench.hpp).
int run_step(const BenchOptions& o) {
  if (o.backend == "cpu") return run_cpu(o);
#if FASCIA_WITH_CUDA
  std::string gpu_name;
  if (!cuda_device_available(&gpu_name)) {
    std::cerr << "fascia bench step: no CUDA device\n";
    return kUnavailable;
  }
  const LinearMethod linear = parse_linear_method(o.linear);
  if (!o.json)
    std::printf("CUDA (%s, %s): ms per full implicit step (1 Newton iteration, %d %s iterations), mean\n",
                gpu_name.c_str(), o.precision.c_str(), o.cg_iterations, o.linear.c_str());
  for (const PaperTiming& p : paper_table3()) {
    if (!o.sizes.empty() && std::find(o.sizes.begin(), o.sizes.end(), p.samples) == o.sizes.end()) continue;
    const Model model = bench_beam_model(p.samples, 4);
    const double ms = time_cuda_step(model, linear, o.cg_iterations, o.precision, o.repeats);
    if (o.json) {
      nlohmann::json j = {{"backend", "cuda"},          {"gpu", gpu_name},
                          {"samples", model.sample_count()}, {"frames", model.frame_count()},
                          {"neighbours", model.max_neighbours()}, {"precision", o.precision},
                          {"linear", o.linear},
                          {"cg_iterations", o.cg_iterations}, {"ms_per_step", ms},
                          {"paper_gpu_ms", p.gpu_ms},    {"paper_samples", p.samples}};
      std::cout << j.dump() << std::endl;
    } else {
      std::printf("%8d %7d %4d %10.3f ms (paper GTX 570 %.2f ms)\n", model.sample_count(), model.frame_count(),
                  model.max_neighbours(), ms, p.gpu_ms);
      std::fflush(stdout);
    }
  }
  return kOk;
#else
  std::cerr << "fascia bench step: this build has no CUDA backend (configure with -DFASCIA_WITH_CUDA=ON)\n";
  return kUnavailable;
#endif
}

int run_cpu(const BenchOptions& o) {
  std::vector<int> threads = {1};
  if (omp_get_max_threads() > 1) threads.push_back(omp_get_max_threads());
  if (!o.json) {
    std::printf("CPU: ms per full implicit step (1 Newton iteration, %d %s iterations), median\n", o.cg_iterations,
                o.linear.c_str());
    std::printf("%8s %7s %4s %8s %10s %10s %10s %9s\n", "samples", "frames", "nbrs", "threads", "ms/step",
                "cpu ms", "paper ms", "speed-up");
  }
  for (const PaperTiming& p : paper_table3()) {
    if (!o.sizes.empty() && std::find(o.sizes.begin(), o.sizes.end(), p.samples) == o.sizes.end()) continue;
    const Model model = bench_beam_model(p.samples, 4);
    for (int t : threads) {
      const StepTiming r = time_cpu_step(model, t, o.cg_iterations, o.min_seconds, parse_linear_method(o.linear));
      if (o.json) {
        nlohmann::json j = {{"backend", "cpu"},           {"linear", o.linear},
                            {"samples", r.samples},       {"frames", r.frames},
                            {"neighbours", r.neighbours}, {"threads", r.threads},
                            {"cg_iterations", r.cg_iterations}, {"ms_per_step", r.ms_per_step},
                            {"cpu_ms_per_step", r.cpu_ms_per_step},
                            {"paper_ms", p.cpu_ms},       {"paper_samples", p.samples}};
        std::cout << j.dump() << std::endl;
      } else {
        std::printf("%8d %7d %4d %8d %10.2f %10.2f %10.2f %8.1fx\n", r.samples, r.frames, r.neighbours, r.threads,
                    r.ms_per_step, r.cpu_ms_per_step, p.cpu_ms, p.cpu_ms / r.ms_per_step);
        std::fflush(stdout);
      }
    }
  }
  return kOk;
}

}  // namespace

void register_bench(CLI::App& app, Action& action) {
  CLI::App* bench = app.add_subcommand("bench", "Benchmarks (timings, not tests)");
  bench->require_subcommand(1);
  auto options = std::make_shared<BenchOptions>();
  CLI::App* cpu = bench->add_subcommand("cpu", "ms per full implicit step on the CPU at the paper's Table 3 sizes");
  cpu->add_flag("--json", options->json, "One JSON object per line on stdout");
  cpu->add_option("--cg-iterations", options->cg_iterations, "CG iterations per step (paper: 60)")
      ->check(kPositiveNumber);
  cpu->add_option("--min-seconds", options->min_seconds, "Minimum timed seconds per size")->check(kPositiveNumber);
  cpu->add_option("--samples", options->sizes, "Only these Table 3 sizes");
  cpu->add_option("--linear", options->linear, "cg (the paper's) | pcg (block Jacobi)")
      ->check(CLI::IsMember({"cg", "pcg"}));
  cpu->callback([options, &action] { action = [options] { return run_cpu(*options); }; });

  auto step_options = std::make_shared<BenchOptions>();
  CLI::App* step = bench->add_subcommand(
      "step", "ms per full implicit step at the paper's Table 3 sizes on the CPU or the CUDA backend (same step)");
  step->add_option("--backend", step_options->backend, "cpu | cuda")->check(CLI::IsMember({"cpu", "cuda"}));
  step->add_flag("--json", step_options->json, "One JSON object per line on stdout");
  step->add_option("--cg-iterations", step_options->cg_iterations, "CG iterations per step (paper: 60)")
      ->check(kPositiveNumber);
  step->add_option("--linear", step_options->linear, "cg (the paper's) | pcg (block Jacobi)")
      ->check(CLI::IsMember({"cg", "pcg"}));
  step->add_option("--samples", step_options->sizes, "Only these Table 3 sizes");
  step->add_option("--min-seconds", step_options->min_seconds, "cpu: minimum timed seconds per size")
      ->check(kPositiveNumber);
  step->add_option("--precision", step_options->precision, "cuda: double | single")
      ->check(CLI::IsMember({"double", "single"}));
  step->add_option("--repeats", step_options->repeats, "cuda: timed steps per size")->check(kPositiveNumber);
  step->callback([step_options, &action] { action = [step_options] { return run_step(*step_options); }; });
  add_bench_discretise(*bench, action);
  add_bench_scenes(*bench, action);
#if FASCIA_WITH_CUDA
  add_bench_gpu_command(*bench, action);
#endif
}

}  // namespace fascia::app
