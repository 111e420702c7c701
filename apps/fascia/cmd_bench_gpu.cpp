#include "cmd_bench_gpu.hpp"

#include "bench/step_bench.hpp"
#include "cuda_step.hpp"
#include "device_elasticity.hpp"
#include "discretise/mesh_based.hpp"
#include "integrate/simulation.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace fascia::app {
namespace {

// A block of hexahedra with 2x2x2 samples each (8 neighbours), about `target` samples.
Model hex_block(long long target) {
  const long long cells = std::max(1LL, target / 8);
  // nx = 2 ny = 2 nz.
  const int nz = std::max(1, static_cast<int>(std::lround(std::cbrt(cells / 4.0))));
  const int ny = nz, nx = static_cast<int>(std::max(1LL, cells / (static_cast<long long>(ny) * nz)));
  const double h = 0.01;
  const VolumeMesh mesh = box_hex_mesh({0, 0, 0}, {h * nx, h * ny, h * nz}, nx, ny, nz);
  Model model = build_mesh_model(mesh, make_material(MaterialLaw::stvk, 1e5, 0.3, 1000), {});
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  return model;
}

struct Row {
  std::string gpu;
  int samples = 0, frames = 0, neighbours = 0;
  std::string precision, pass, linear;
  double ms_per_step = 0, ms_per_cg_iteration = 0, tangent_ms = 0, tangent_gbs = 0, peak_gbs = 0;
  int tangent_registers = 0;            // the launched tangent sample kernel's registers per thread
  long long tangent_local_bytes = 0;    // ... and local memory per thread (spills)
  double paper_ms = NAN, paper_cpu_ms = NAN;
};

struct Case {
  gpu::Precision precision;
  LinearMethod linear;
};

// Prints "<what> not used: <why>" to stderr once per run for each distinct reason (every size and
// precision would otherwise repeat it); nothing where `why` is empty.
void note_refusal(const char* what, const std::string& why) {
  static std::set<std::string> printed;
  if (why.empty()) return;
  const std::string line = std::string(what) + " not used: " + why;
  if (printed.insert(line).second) std::fprintf(stderr, "%s\n", line.c_str());
}

// The benchmark step of engine/bench/step_bench.hpp (the one `fascia bench cpu` times) taken as
// `fascia run --backend cuda` takes a step (kernels/cuda_step.hpp): the start state uploaded, the
// one Newton and PCG on the device potential, the result read back; timed on the host.
class DeviceBenchStep {
 public:
  DeviceBenchStep(const Model& model, gpu::Precision precision) : m_loads(bench_step_loads()), m_start(rest_state(model)) {
    gpu::DeviceOptions options;
    options.precision = precision;
    SimulationSettings settings;
    settings.integrator = Integrator::backward_euler;
    settings.dt = kBenchStepDt;
    settings.newton.fixed_iterations = 1;
    settings.newton.linear = bench_linear_settings(LinearMethod::pcg, 60);
    std::string why;
    m_backend = gpu::cuda_step_factory(options)(model, m_loads, settings, why);
    if (!m_backend) throw std::runtime_error("the CUDA step does not cover the benchmark model: " + why);
  }

  // Mean ms of a step whose solve runs exactly `cg_iterations` iterations of `linear`, over
  // `repeats` steps from the start state after one warm-up step.
  double ms_per_step(LinearMethod linear, int cg_iterations, int repeats) {
    NewtonSettings newton;
    newton.fixed_iterations = 1;
    newton.linear = bench_linear_settings(linear, cg_iterations);
    State trial = m_start;
    m_backend->backward_euler(m_start, trial, kBenchStepDt, 0.0, newton, 0.0);
    double seconds = 0;
    for (int k = 0; k < repeats; ++k) {
      trial = m_start;
      const auto t0 = std::chrono::steady_clock::now();
      m_backend->backward_euler(m_start, trial, kBenchStepDt, 0.0, newton, 0.0);
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    return 1e3 * seconds / repeats;
  }

 private:
  ExternalLoads m_loads;
  State m_start;
  std::unique_ptr<StepBackend> m_backend;
};

Row measure(const Model& model, const Case& c, int repeats, const gpu::DeviceInfo& info, bool tangent) {
  Row row;
  row.gpu = info.name;
  row.samples = model.sample_count();
  row.frames = model.frame_count();
  row.neighbours = model.max_neighbours();
  row.precision = gpu::to_string(c.precision);
  row.linear = to_string(c.linear);
  {
    DeviceBenchStep step(model, c.precision);
    row.ms_per_step = step.ms_per_step(c.linear, 60, repeats);
    // A CG iteration: the step with 60 iterations against the step with one.
    row.ms_per_cg_iteration = (row.ms_per_step - step.ms_per_step(c.linear, 1, repeats)) / 59;
  }
  gpu::DeviceOptions options;
  options.precision = c.precision;
  gpu::DeviceElasticity dev(model, options);
  note_refusal("grouped pass", dev.group_samples_refusal());
  row.pass = dev.group_samples() ? "grouped" : "coalesced";
  if (tangent) {
    dev.set_state(rest_state(model));
    dev.prepare();
    row.tangent_ms = dev.time_tangent_ms(std::max(10, 5 * repeats));
    row.tangent_gbs = dev.tangent_bytes() / (row.tangent_ms * 1e-3) / 1e9;
    const gpu::KernelResources k = dev.tangent_kernel_resources();
    row.tangent_registers = k.registers;
    row.tangent_local_bytes = k.local_bytes;
  }
  row.peak_gbs = info.peak_bandwidth_gbs;
  return row;
}

void print(const Row& r, bool json) {
  if (json) {
    nlohmann::json j = {{"gpu", r.gpu},
                        {"samples", r.samples},
                        {"frames", r.frames},
                        {"neighbours", r.neighbours},
                        {"precision", r.precision},
                        {"pass", r.pass},
                        {"linear", r.linear},
                        {"ms_per_step", r.ms_per_step},
                        {"ms_per_cg_iteration", r.ms_per_cg_iteration},
                        {"tangent_ms", r.tangent_ms},
                        {"tangent_gbs", r.tangent_gbs},
                        {"tangent_registers", r.tangent_registers},
                        {"tangent_local_bytes", r.tangent_local_bytes},
                        {"peak_gbs", r.peak_gbs}};
    j["paper_ms"] = std::isnan(r.paper_ms) ? nlohmann::json(nullptr) : nlohmann::json(r.paper_ms);
    j["paper_cpu_ms"] = std::isnan(r.paper_cpu_ms) ? nlohmann::json(nullptr) : nlohmann::json(r.paper_cpu_ms);
    std::cout << j.dump() << std::endl;
    return;
  }
  char paper[64] = "      -        -";
  if (!std::isnan(r.paper_ms)) std::snprintf(paper, sizeof paper, "%8.2f %8.2f", r.paper_cpu_ms, r.paper_ms);
  std::printf("%9d %8d %3d %-6s %-9s %-3s %10.3f %10.4f %17s %9.4f %7.0f (%3.0f%%)\n", r.samples, r.frames,
              r.neighbours, r.precision.c_str(), r.pass.c_str(), r.linear.c_str(), r.ms_per_step, r.ms_per_cg_iteration, paper, r.tangent_ms, r.tangent_gbs,
              r.peak_gbs > 0 ? 100 * r.tangent_gbs / r.peak_gbs : 0.0);
  std::fflush(stdout);
}

std::vector<Case> cases(const BenchGpuOptions& o) {
  std::vector<Case> out;
  for (gpu::Precision pr : {gpu::Precision::double_precision, gpu::Precision::single_precision}) {
    if (o.precision != "both" && o.precision != gpu::to_string(pr)) continue;
    for (LinearMethod lm : {LinearMethod::cg, LinearMethod::pcg}) {
      if (o.linear != "both" && o.linear != to_string(lm)) continue;
      out.push_back(Case{pr, lm});
    }
  }
  return out;
}

}  // namespace

double time_cuda_step(const Model& model, LinearMethod linear, int cg_iterations, const std::string& precision,
                      int repeats) {
  DeviceBenchStep step(model, precision == "single" ? gpu::Precision::single_precision : gpu::Precision::double_precision);
  return step.ms_per_step(linear, cg_iterations, repeats);
}

bool cuda_device_available(std::string* name) {
  const gpu::DeviceInfo info = gpu::device_info();
  if (name) *name = info.name;
  return info.device_count > 0;
}

int run_bench_gpu(const BenchGpuOptions& o) {
  const gpu::DeviceInfo info = gpu::device_info();
  if (info.device_count == 0) {
    std::cerr << "fascia bench gpu: no CUDA device\n";
    return kUnavailable;
  }
  const std::vector<Case> all = cases(o);
  const int repeats = o.quick ? 3 : o.repeats;
  if (!o.json) {
    std::printf("fascia bench gpu on %s (%d SMs, %.0f GiB, peak DRAM %.0f GB/s from clock x bus width)\n",
                info.name.c_str(), info.multiprocessors, info.memory_gib, info.peak_bandwidth_gbs);
    std::printf("ms per full implicit step (the step of `fascia bench cpu`) as `fascia run --backend cuda` takes\n"
                "it: upload, forces + preparation + 60 CG iterations + update, read back; host clock\n");
    std::printf("%9s %8s %3s %-6s %-9s %-3s %10s %10s %8s %8s %9s %15s\n", "samples", "frames", "nb", "prec",
                "Kd pass", "lin", "ms/step", "ms/CG it", "CPU'13", "GTX570", "Kd ms", "Kd GB/s (peak)");
  }
  for (const PaperTiming& p : paper_table3()) {
    if (!o.sizes.empty() && std::find(o.sizes.begin(), o.sizes.end(), p.samples) == o.sizes.end()) continue;
    const Model model = bench_beam_model(p.samples, 4);
    for (const Case& c : all) {
      Row r = measure(model, c, repeats, info, o.tangent);
      r.paper_ms = p.gpu_ms;
      r.paper_cpu_ms = p.cpu_ms;
      print(r, o.json);
    }
  }
  std::vector<long long> scaling = {131072, 524288, 1048576, 2097152, o.max_samples};
  if (o.quick) scaling = {o.max_samples};
  if (o.max_samples <= 0) scaling.clear();
  for (long long target : scaling) {
    if (target > o.max_samples) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const Model model = hex_block(target);
    const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::fprintf(stderr, "built %d samples in %.1f s\n", model.sample_count(), build_s);
    for (const Case& c : all) print(measure(model, c, repeats, info, true), o.json);
  }
  return 0;
}

void add_bench_gpu_command(CLI::App& bench, Action& action) {
  auto options = std::make_shared<BenchGpuOptions>();
  CLI::App* cmd = bench.add_subcommand("gpu", "ms per implicit step on the CUDA backend (paper Table 3 sizes, scaling)");
  cmd->add_flag("--json", options->json, "one JSON object per line");
  cmd->add_flag("--quick", options->quick, "Table 3 sizes and the largest case only, fewer repeats");
  cmd->add_option("--precision", options->precision, "double | single | both")
      ->check(CLI::IsMember({"double", "single", "both"}));
  cmd->add_option("--linear", options->linear, "cg | pcg | both (the linear solve of the step)")
      ->check(CLI::IsMember({"cg", "pcg", "both"}));
  cmd->add_option("--samples", options->sizes, "only these Table 3 sizes");
  cmd->add_flag("--tangent", options->tangent, "also time the tangent product alone at Table 3 sizes");
  cmd->add_option("--max-samples", options->max_samples, "largest scaling case (8 neighbours), 0: none");
  cmd->add_option("--repeats", options->repeats, "timed repeats per case");
  cmd->callback([options, &action] { action = [options] { return run_bench_gpu(*options); }; });
}

}  // namespace fascia::app
