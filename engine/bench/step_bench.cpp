#include "bench/step_bench.hpp"

#include "discretise/mesh_based.hpp"
#include "integrate/step_potential.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>

namespace fascia {
namespace {

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

const std::vector<PaperTiming>& paper_table3() {
  static const std::vector<PaperTiming> table = {
      {800, 78.42, 15.25},     {2600, 251.77, 17.11},   {6070, 595.77, 23.39},   {12700, 1228.8, 32.29},
      {16210, 1561.8, 39.29},  {19990, 1990.06, 43.12}, {26750, 2675.47, 53.09}, {34610, 3468.54, 66.1}};
  return table;
}

Model bench_beam_model(int samples, int neighbours_per_sample) {
  // Cross-section n x n cells, length nx = 4n or as needed to reach the sample count.
  const int per_cell = neighbours_per_sample == 8 ? 1 : 6;
  const int cells = std::max(1, samples / per_cell);
  const int n = std::max(1, static_cast<int>(std::round(std::cbrt(cells / 4.0))));
  const int nx = std::max(1, static_cast<int>(std::round(static_cast<double>(cells) / (n * n))));
  const Vec3 lo{0, 0, 0}, hi{4.0 * nx / (4.0 * n), 0.25, 0.25};
  const Material m = make_material(MaterialLaw::stvk, 40e3, 0.3, 1000);
  Model model = neighbours_per_sample == 8 ? build_mesh_model(box_hex_mesh(lo, hi, nx, n, n), m, {1})
                                           : build_mesh_model(box_tet_mesh(lo, hi, nx, n, n), m, {1});
  fix_frames(model, [](double x, double, double) { return x <= 1e-12; });
  return model;
}

ExternalLoads bench_step_loads() {
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  return loads;
}

LinearSettings bench_linear_settings(LinearMethod method, int cg_iterations) {
  LinearSettings linear;
  linear.method = method;
  linear.preconditioner = Preconditioner::block_jacobi;  // matrix-free, as on the device
  linear.fixed_iterations = true;
  linear.max_iterations = cg_iterations;
  return linear;
}

StepTiming time_cpu_step(const Model& model, int threads, int cg_iterations, double min_seconds, LinearMethod method) {
  const ExternalLoads loads = bench_step_loads();
  StepPotential potential(model, loads, threads);
  NewtonSettings newton;
  newton.fixed_iterations = 1;
  newton.linear = bench_linear_settings(method, cg_iterations);
  State state = rest_state(model);
  std::vector<double> ms, cpu_ms;
  double total = 0;
  int cg = 0;
  for (int rep = 0; rep < 1000; ++rep) {
    const double c0 = process_cpu_seconds();
    const auto t0 = std::chrono::steady_clock::now();
    potential.set_dynamic(state, kBenchStepDt, 0, 0);
    const NewtonResult r = minimise(potential, state, newton, 0.0);
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double dc = process_cpu_seconds() - c0;
    cg = r.cg_iterations;
    if (rep == 0) continue;  // warm-up
    ms.push_back(1e3 * dt);
    cpu_ms.push_back(1e3 * dc);
    total += dt;
    if (total >= min_seconds && ms.size() >= 3) break;
  }
  std::sort(ms.begin(), ms.end());
  std::sort(cpu_ms.begin(), cpu_ms.end());
  StepTiming t;
  t.samples = model.sample_count();
  t.frames = model.frame_count();
  t.neighbours = model.max_neighbours();
  t.threads = potential.threads();
  t.cg_iterations = cg;
  t.ms_per_step = ms[ms.size() / 2];
  t.cpu_ms_per_step = cpu_ms[cpu_ms.size() / 2];
  t.repetitions = static_cast<int>(ms.size());
  return t;
}

}  // namespace fascia
