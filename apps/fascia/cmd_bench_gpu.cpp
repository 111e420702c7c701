#include "cmd_bench_gpu.hpp"

#include "device_elasticity.hpp"
#include "discretise/mesh_based.hpp"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <vector>

namespace fascia::app {
namespace {

// The paper's Table 3: samples, CPU ms, GTX 570 ms per step (60 CG iterations, 4 neighbours).
struct PaperRow {
  int samples;
  double cpu_ms, gpu_ms;
};
constexpr PaperRow kTable3[] = {{800, 78.42, 15.25},     {2600, 251.77, 17.11},   {6070, 595.77, 23.39},
                                {12700, 1228.8, 32.29},  {16210, 1561.8, 39.29},  {19990, 1990.06, 43.12},
                                {26750, 2675.47, 53.09}, {34610, 3468.54, 66.1}};

// A beam of tetrahedra with one sample each (4 neighbours) and about `target` samples:
// 6 nx ny ny tetrahedra, nx >= ny, closest count.
Model tet_beam(int target) {
  int best_nx = 1, best_ny = 1;
  long long best = -1;
  for (int ny = 1; ny <= 64; ++ny) {
    const int nx = std::max(ny, static_cast<int>(std::lround(target / (6.0 * ny * ny))));
    const long long count = 6LL * nx * ny * ny;
    if (best < 0 || std::llabs(count - target) < std::llabs(best - target)) {
      best = count;
      best_nx = nx;
      best_ny = ny;
    }
  }
  const double h = 0.01;
  const VolumeMesh mesh = box_tet_mesh({0, 0, 0}, {h * best_nx, h * best_ny, h * best_ny}, best_nx, best_ny, best_ny);
  MeshDiscretisation disc;
  disc.quadrature = 1;
  return build_mesh_model(mesh, make_material(MaterialLaw::stvk, 1e5, 0.3, 1000), disc);
}

// A block of hexahedra with 2x2x2 samples each (8 neighbours), about `target` samples.
Model hex_block(long long target) {
  const long long cells = std::max(1LL, target / 8);
  // nx = 2 ny = 2 nz.
  const int nz = std::max(1, static_cast<int>(std::lround(std::cbrt(cells / 4.0))));
  const int ny = nz, nx = static_cast<int>(std::max(1LL, cells / (static_cast<long long>(ny) * nz)));
  const double h = 0.01;
  const VolumeMesh mesh = box_hex_mesh({0, 0, 0}, {h * nx, h * ny, h * nz}, nx, ny, nz);
  return build_mesh_model(mesh, make_material(MaterialLaw::stvk, 1e5, 0.3, 1000), {});
}

struct Row {
  std::string gpu;
  int samples = 0, frames = 0, neighbours = 0;
  std::string precision, design;
  double ms_per_step = 0, ms_per_cg_iteration = 0, tangent_ms = 0, tangent_gbs = 0, peak_gbs = 0;
  double paper_ms = NAN, paper_cpu_ms = NAN;
};

Row measure(const Model& input, gpu::Precision precision, gpu::Design design, int repeats, const gpu::DeviceInfo& info) {
  Model model = input;
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  gpu::DeviceOptions options;
  options.precision = precision;
  options.design = design;
  gpu::DeviceElasticity dev(model, options);
  dev.set_state(rest_state(model));
  gpu::StepOptions so;
  so.dt = 0.01;
  so.max_cg_iterations = 60;
  so.external_forces.assign(model.dof_count(), 0.0);
  for (int i = 0; i < model.frame_count(); ++i) so.external_forces[6 * i + 1] = -9.81 * model.frame_masses[i];
  gpu::DeviceBackwardEuler stepper(dev, so);
  Row row;
  row.gpu = info.name;
  row.samples = model.sample_count();
  row.frames = model.frame_count();
  row.neighbours = model.max_neighbours();
  row.precision = gpu::to_string(precision);
  row.design = gpu::to_string(dev.design());
  row.ms_per_step = stepper.time_step_ms(repeats);
  row.ms_per_cg_iteration = stepper.time_cg_iteration_ms(std::max(1, repeats / 2));
  dev.prepare();
  row.tangent_ms = dev.time_tangent_ms(std::max(10, 5 * repeats));
  row.tangent_gbs = dev.tangent_bytes() / (row.tangent_ms * 1e-3) / 1e9;
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
                        {"design", r.design},
                        {"ms_per_step", r.ms_per_step},
                        {"ms_per_cg_iteration", r.ms_per_cg_iteration},
                        {"tangent_ms", r.tangent_ms},
                        {"tangent_gbs", r.tangent_gbs},
                        {"peak_gbs", r.peak_gbs}};
    j["paper_ms"] = std::isnan(r.paper_ms) ? nlohmann::json(nullptr) : nlohmann::json(r.paper_ms);
    j["paper_cpu_ms"] = std::isnan(r.paper_cpu_ms) ? nlohmann::json(nullptr) : nlohmann::json(r.paper_cpu_ms);
    std::cout << j.dump() << std::endl;
    return;
  }
  char paper[64] = "      -        -";
  if (!std::isnan(r.paper_ms)) std::snprintf(paper, sizeof paper, "%8.2f %8.2f", r.paper_cpu_ms, r.paper_ms);
  std::printf("%9d %8d %3d %-6s %-5s %10.3f %10.4f %17s %9.4f %7.0f (%3.0f%%)\n", r.samples, r.frames, r.neighbours,
              r.precision.c_str(), r.design.c_str(), r.ms_per_step, r.ms_per_cg_iteration, paper, r.tangent_ms,
              r.tangent_gbs, r.peak_gbs > 0 ? 100 * r.tangent_gbs / r.peak_gbs : 0.0);
  std::fflush(stdout);
}

}  // namespace

int run_bench_gpu(const BenchGpuOptions& o) {
  const gpu::DeviceInfo info = gpu::device_info();
  if (info.device_count == 0) {
    std::cerr << "fascia bench gpu: no CUDA device\n";
    return 69;
  }
  std::vector<gpu::Precision> precisions;
  if (o.precision != "single") precisions.push_back(gpu::Precision::double_precision);
  if (o.precision != "double") precisions.push_back(gpu::Precision::single_precision);
  std::vector<gpu::Design> designs;
  if (o.design != "paper") designs.push_back(gpu::Design::fused);
  if (o.design != "fused") designs.push_back(gpu::Design::paper);
  const int repeats = o.quick ? 3 : o.repeats;
  if (!o.json) {
    std::printf("fascia bench gpu on %s (%d SMs, %.0f GiB, peak DRAM %.0f GB/s from clock x bus width)\n",
                info.name.c_str(), info.multiprocessors, info.memory_gib, info.peak_bandwidth_gbs);
    std::printf("ms per full implicit step: forces + preparation + PCG with 60 iterations + update, CUDA events\n");
    std::printf("%9s %8s %3s %-6s %-5s %10s %10s %8s %8s %9s %15s\n", "samples", "frames", "nb", "prec", "design",
                "ms/step", "ms/CG it", "CPU'13", "GTX570", "Kd ms", "Kd GB/s (peak)");
  }
  for (const PaperRow& p : kTable3) {
    const Model model = tet_beam(p.samples);
    for (gpu::Precision pr : precisions)
      for (gpu::Design de : designs) {
        Row r = measure(model, pr, de, repeats, info);
        r.paper_ms = p.gpu_ms;
        r.paper_cpu_ms = p.cpu_ms;
        print(r, o.json);
      }
  }
  std::vector<long long> scaling = {131072, 524288, 1048576, 2097152, o.max_samples};
  if (o.quick) scaling = {o.max_samples};
  for (long long target : scaling) {
    if (target > o.max_samples) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const Model model = hex_block(target);
    const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (!o.json) std::fprintf(stderr, "built %d samples in %.1f s\n", model.sample_count(), build_s);
    for (gpu::Precision pr : precisions)
      for (gpu::Design de : designs) print(measure(model, pr, de, repeats, info), o.json);
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
  cmd->add_option("--design", options->design, "fused | paper | both")->check(CLI::IsMember({"fused", "paper", "both"}));
  cmd->add_option("--max-samples", options->max_samples, "largest scaling case (8 neighbours)");
  cmd->add_option("--repeats", options->repeats, "timed repeats per case");
  cmd->callback([options, &action] { action = [options] { return run_bench_gpu(*options); }; });
}

}  // namespace fascia::app
