// Simulations on the CUDA backend (`fascia run --backend cuda`, `fascia study beam --backend
// cuda`) against the CPU engine: with the volumetric elasticity alone on the device
// (CudaElasticity: the Newton solver, loads, shells and rigid mapping run on the CPU in both, the
// elasticity differs in summation order), and the study row and the resumed runs with the whole
// step on the device (cuda_step.hpp).
//
// Bounds. Each step starts both backends from the same state and must end within the
// a-posteriori distance of support/minimiser_bound.hpp: both runs stop at |g_free| <= tau F, so
// each lies within |g_free| / lambda_min of the exact minimiser (gradients re-evaluated by the
// CPU engine, lambda_min the smallest eigenvalue of the free Hessian). With tau = 1e-10 this is
// far below 1e-9 relative; the device's own round-off (energy, forces, tangent within 1e-12
// relative, test_device_elasticity.cpp) enters only through the gradient at which Newton stops,
// which the bound measures.
#include "cuda_elasticity.hpp"
#include "cuda_step.hpp"
#include "discretise/mesh_based.hpp"
#include "discretise/probe.hpp"
#include "mechanics/frame_loads.hpp"
#include "study/beam_study.hpp"
#include "support/backend_comparison.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/resume_check.hpp"

#include <catch2/catch.hpp>

#include <cstdio>

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

namespace {

SimulationSettings comparison_settings(Integrator integrator, LinearMethod method) {
  SimulationSettings s;
  s.integrator = integrator;
  s.dt = 0.01;
  s.rayleigh_mass = 0.5;
  s.rayleigh_stiffness = 0.002;  // the start-of-step tangent on the device too
  s.newton.tolerance = 1e-10;
  s.newton.linear.method = method;
  s.newton.linear.tolerance = 1e-10;
  return s;
}

ExternalLoads gravity() {
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  return loads;
}

// The study's frame-tet 4 x 1 x 1 cantilever (study/beam_study.cpp, discretise_beam): 16 x 1 x 1 m,
// 5 kg, StVK E = 40 kPa, nu = 0.3, clamped at x = 0.
Model study_beam_model(const BeamSettings& s) {
  const VolumeMesh mesh = box_tet_mesh({0, 0, 0}, {s.length, s.width, s.height}, 4, 1, 1);
  const double density = s.mass / (s.length * s.width * s.height);
  Model model = build_mesh_model(mesh, make_material(s.law, s.young, s.poisson, density));
  const double clamp = 1e-9 * s.length;
  fix_frames(model, [clamp](double x, double, double) { return x <= clamp; });
  return model;
}

}  // namespace

TEST_CASE("backward Euler on a tissue block: CUDA backend equals the CPU engine", "[gpu]") {
  const LinearMethod method = GENERATE(LinearMethod::pcg, LinearMethod::cholmod);
  Model model = small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 4, 3, 2);
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  char label[64];
  std::snprintf(label, sizeof label, "gpu block %s", to_string(method));
  const double worst = check_backends_agree(label, model, gravity(), comparison_settings(Integrator::backward_euler, method),
                                            cuda_elasticity_factory(), 3);
  CHECK(worst <= 1.0);
}

TEST_CASE("backward Euler and a static solve of a coupled scene: CUDA backend equals the CPU engine", "[gpu]") {
  // Tetrahedral block (no zero-energy modes, so the static Hessian is definite), its top frames
  // shared with a shell, its bottom frames on a fixed rigid plate.
  const Integrator integrator = GENERATE(Integrator::backward_euler, Integrator::static_equilibrium);
  const LinearMethod method = GENERATE(LinearMethod::pcg, LinearMethod::cholmod);
  const Model model = coupled_model(CellType::tetrahedron, true);
  char label[64];
  std::snprintf(label, sizeof label, "gpu coupled %s %s", to_string(integrator), to_string(method));
  const int steps = integrator == Integrator::backward_euler ? 3 : 1;
  const double worst = check_backends_agree(label, model, gravity(), comparison_settings(integrator, method),
                                            cuda_elasticity_factory(), steps);
  CHECK(worst <= 1.0);
}

TEST_CASE("static cantilever: CUDA backend equals the CPU engine", "[gpu]") {
  // Large deflection (tip about 2.3 m of 16 m): load stepping, line search and the assembled
  // tangent (CHOLMOD, from the CPU reference prepared at the device's state).
  const LinearMethod method = GENERATE(LinearMethod::cholmod, LinearMethod::pcg);
  const Model model = study_beam_model(BeamSettings{});
  SimulationSettings settings = comparison_settings(Integrator::static_equilibrium, method);
  settings.newton.max_iterations = 300;
  const double worst = check_backends_agree(method == LinearMethod::cholmod ? "gpu beam cholmod" : "gpu beam pcg", model,
                                            gravity(), settings, cuda_elasticity_factory(), 1);
  CHECK(worst <= 1.0);
}

TEST_CASE("backward Euler in single precision converges to the CPU engine's tolerance", "[gpu]") {
  // Single storage holds the tangent; energies and gradients are evaluated in double
  // (DeviceElasticity's double copy), and stiffness-proportional damping's K(q_n) dq, a term of
  // the gradient, comes from a start-of-step elasticity in double (ElasticityUse::damping), so
  // Newton reaches the comparison's tolerance of 1e-10 as in double; the bound is a-posteriori
  // (CPU gradients at both end states). With K(q_n) dq in float the gradient would carry an error
  // of about 1e-7 of the damping force and Newton would stall above that tolerance.
  Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk, 4, 3, 2);
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  SimulationSettings settings = comparison_settings(Integrator::backward_euler, LinearMethod::pcg);
  DeviceOptions options;
  options.precision = Precision::single_precision;
  const double worst = check_backends_agree("gpu block single", model, gravity(), settings,
                                            cuda_elasticity_factory(options), 3);
  CHECK(worst <= 1.0);
}

TEST_CASE("a beam study row on the CUDA backend equals the CPU row", "[gpu]") {
  // `fascia study beam --method frame-tet --resolution 4x1x1`, tolerance 1e-7 of the weight.
  BeamSettings cpu_settings, gpu_settings;
  gpu_settings.elasticity = cuda_elasticity_factory();
  gpu_settings.step_backend = cuda_step_factory();  // the row's static solve on the device
  const BeamCase row{"frame-tet", 4, 1, 1};
  const BeamResult cpu = run_beam_case(row, cpu_settings);
  const BeamResult gpu = run_beam_case(row, gpu_settings);
  REQUIRE(cpu.converged);
  REQUIRE(gpu.converged);
  CHECK(gpu.frames == cpu.frames);
  CHECK(gpu.samples == cpu.samples);

  // Bound: each run stops at |g_free| <= residual * F, F = |f_ext| (the reference force of the
  // last load increment; at its start the gradient is a fraction of f_ext); the tip is
  // sum_i w_i (x_i + R_i l_i), so |d tip| <= (1 + extent) |dq|. lambda_min at the CPU solution.
  const Model model = study_beam_model(cpu_settings);
  ExternalLoads loads = gravity();
  SimulationSettings settings = comparison_settings(Integrator::static_equilibrium, LinearMethod::cholmod);
  settings.newton.max_iterations = 300;
  Simulation solved(model, loads, settings);
  solved.step();
  StepPotential probe(solved.model(), solved.loads());
  probe.set_static();
  const MinimiserBound b = minimiser_bound(probe, solved.state(), solved.state());
  const double F = FrameLoads(solved.model(), solved.loads()).force_norm(solved.loads().scale);
  const double bound = (1 + b.extent) * 2 * (cpu.residual + gpu.residual) * F / b.lambda_min +
                       state_round_off(cpu_settings.length);
  const double diff = norm(gpu.tip_displacement - cpu.tip_displacement);
  std::printf("[gpu study] frame-tet 4x1x1: tip dz cpu %.9f gpu %.9f, |difference| %.2e (bound %.2e), newton %d/%d, "
              "residual %.1e/%.1e\n",
              cpu.tip_displacement.z, gpu.tip_displacement.z, diff, bound, cpu.newton_iterations, gpu.newton_iterations,
              cpu.residual, gpu.residual);
  REQUIRE(b.lambda_min > 0);
  CHECK(diff <= bound);
  // The study's own check: the tip moved as much as the row in the README (-2.347 m).
  CHECK(cpu.tip_displacement.z == Approx(-2.347).margin(5e-4));
}

TEST_CASE("a CUDA run restored from its checkpoint continues bit for bit", "[gpu][resume]") {
  // `fascia run --backend cuda --resume` (docs/hpc.md): the whole step on the device (cuda_step.hpp)
  // restored from what a checkpoint keeps. With the default cholmod preconditioner the
  // device keeps its factorisation across steps and the checkpoint records where it was computed
  // (Simulation::restore_tangent computes it again); with block Jacobi only the state carries.
  // The continued steps equal the uninterrupted run's bit for bit: the device's summation order
  // is fixed (no atomics).
  const Integrator integrator =
      GENERATE(Integrator::backward_euler, Integrator::static_equilibrium, Integrator::variational);
  const Preconditioner preconditioner = GENERATE(Preconditioner::cholmod, Preconditioner::block_jacobi);
  // Hexahedra: static solves carry the rotation stabilisation (device_stabilisation.hpp).
  const CellType cells = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const char* cell_name = cells == CellType::tetrahedron ? "tetrahedra" : "hexahedra";
  INFO(to_string(integrator) << ", pcg + " << to_string(preconditioner) << ", " << cell_name);
  Model model = small_box_model(cells, MaterialLaw::neo_hookean, 4, 3, 2);
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  SimulationSettings settings;
  settings.integrator = integrator;
  settings.dt = 0.01;
  settings.threads = 1;
  settings.load_steps = 2;
  settings.rayleigh_mass = integrator == Integrator::variational ? 0.0 : 0.5;  // a variational step takes none
  settings.newton.linear.preconditioner = preconditioner;
  settings.elasticity = cuda_elasticity_factory();
  settings.step_backend = cuda_step_factory();
  const std::vector<PrescribedMotion> motions{pull_free_end(model)};
  REQUIRE(Simulation(model, gravity(), settings, motions).on_step_backend());
  // Restored at steps 2 to 5: whether the factorisation is held there or renewed before the next
  // solve follows the renewal rule; with cholmod, backward Euler holds it at some of them (these
  // static steps end with it renewed: restored, they factorise first as the full run does).
  int held = 0;
  for (int split = 2; split <= 5; ++split) {
    const ResumeComparison c = compare_resume(model, gravity(), motions, settings, split, 8);
    INFO("restored at step " << split);
    held += c.held;
    CHECK(c.cg_resumed == c.cg_full);
    CHECK(c.resumed.positions == c.full.positions);  // bitwise
    CHECK(c.resumed.orientations == c.full.orientations);
    CHECK(c.resumed.velocities == c.full.velocities);
  }
  std::printf("[resume %s, pcg + %s, %s] factorisation held at %d of 4 restore steps\n", to_string(integrator),
              to_string(preconditioner), cell_name, held);
  if (preconditioner == Preconditioner::block_jacobi) CHECK(held == 0);
  if (preconditioner == Preconditioner::cholmod && integrator == Integrator::backward_euler) CHECK(held > 0);
}
