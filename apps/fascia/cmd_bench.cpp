// `fascia bench cpu`: ms per full implicit step at the paper's Table 3 sizes.
#include "commands.hpp"

#include "bench/step_bench.hpp"
#include "cmd_bench_discretise.hpp"
#if FASCIA_WITH_CUDA
#include "cmd_bench_gpu.hpp"
#endif

#include <nlohmann/json.hpp>
#include <omp.h>

#include <cstdio>
#include <iostream>

namespace fascia::app {
namespace {

struct BenchOptions {
  bool json = false;
  int cg_iterations = 60;
  double min_seconds = 0.5;
  std::vector<int> sizes;
};

int run_cpu(const BenchOptions& o) {
  std::vector<int> threads = {1};
  if (omp_get_max_threads() > 1) threads.push_back(omp_get_max_threads());
  if (!o.json) {
    std::printf("CPU: ms per full implicit step (1 Newton iteration, %d CG iterations), median\n", o.cg_iterations);
    std::printf("%8s %7s %4s %8s %10s %10s %10s %9s\n", "samples", "frames", "nbrs", "threads", "ms/step",
                "cpu ms", "paper ms", "speed-up");
  }
  for (const PaperTiming& p : paper_table3()) {
    if (!o.sizes.empty() && std::find(o.sizes.begin(), o.sizes.end(), p.samples) == o.sizes.end()) continue;
    const Model model = bench_beam_model(p.samples, 4);
    for (int t : threads) {
      const StepTiming r = time_cpu_step(model, t, o.cg_iterations, o.min_seconds);
      if (o.json) {
        nlohmann::json j = {{"samples", r.samples},       {"frames", r.frames},
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
      ->check(CLI::PositiveNumber);
  cpu->add_option("--min-seconds", options->min_seconds, "Minimum timed seconds per size")->check(CLI::PositiveNumber);
  cpu->add_option("--samples", options->sizes, "Only these Table 3 sizes");
  cpu->callback([options, &action] { action = [options] { return run_cpu(*options); }; });
  add_bench_discretise(*bench, action);
#if FASCIA_WITH_CUDA
  add_bench_gpu_command(*bench, action);
#endif
}

}  // namespace fascia::app
