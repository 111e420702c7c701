// The whole step on the device (kernels/cuda_step.hpp) against the CPU engine.
//
// 1. The device potential (device_potential.hpp) against StepPotential at random states: value,
//    gradient, Hessian product and block-Jacobi preconditioner, static and backward Euler, with
//    every kind of load. Bound: 1e-12 relative (norm-wise), as for the elasticity alone
//    (test_device_elasticity.cpp): the frame terms are the same FASCIA_HD bodies in double, and
//    every sum differs from the CPU's in order only.
// 2. Whole steps (Newton, line search, PCG on the device) against the CPU engine in lockstep, and
//    every shipped scene through `fascia run --backend cuda`'s settings: the end states must agree
//    within the a-posteriori bound of support/minimiser_bound.hpp (both runs stop at
//    |g_free| <= tau F; their distance is bounded by the gradients at which they stop over the
//    smallest eigenvalue of the free Hessian, evaluated by the CPU engine).
#include "cuda_elasticity.hpp"
#include "cuda_step.hpp"
#include "device_cholesky.hpp"
#include "device_potential.hpp"
#include "integrate/step_potential.hpp"
#include "integrate/tangent_probing.hpp"
#include "integrate/variational_step.hpp"
#include "mechanics/assembled_tangent.hpp"
#include "mechanics/elasticity.hpp"
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"
#include "mechanics/rigid_mapping.hpp"
#include "mechanics/rotation_stabilisation.hpp"
#include "model/assembly.hpp"
#include "solve/block_jacobi.hpp"
#include "solve/sparse_cholesky.hpp"
#include "support/backend_comparison.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/fixtures.hpp"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <cuda_runtime.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

namespace {

ExternalLoads all_loads(const Model& model) {
  ExternalLoads loads;
  loads.gravity = Vec3{0.5, -1.0, -9.81};
  loads.point_forces.push_back(PointForce{model.frame_count() - 1, Vec3{0.2, -0.1, 0.05}});
  MaterialPointForce mp;
  mp.frames = {model.frame_count() - 2, model.frame_count() - 1};
  mp.weights = {0.4, 0.6};
  mp.rest_offsets = {0.01, 0.0, -0.02, 0.0, 0.02, 0.01};
  mp.force = Vec3{-0.3, 0.2, 0.4};
  loads.material_point_forces.push_back(mp);
  return loads;
}

// A static equilibrium of frame hexahedra is one of several: local minima that differ mostly in
// the frames' rotations (the modes the rotation stabilisation holds weakly), and which one a solve
// reaches depends on its path and rounding. On the CPU alone the tissue block's cg, pcg with
// block Jacobi and cholmod end at three of them (rotations 1.6 and 3.1 rad apart), and the device's
// pcg with the kept factor has ended at yet another (at 0.3 of this load, 1.55 rad from the CPU's).
// So the device's end state is checked as a minimiser of the CPU's potential
// rather than against the CPU's state: the CPU's |g_free| there within twice Newton's stopping
// bound tolerance * S (the two sum in different orders, a relative 1e-14 of the terms), S at most
// max(|f_ext|, |g_free(rest)|) (the force scale of newton.hpp for the one load increment, or for
// the last one after halvings, whose start has a smaller gradient), and the free Hessian positive
// definite there. Returns |g_free| over that bound.
double check_device_equilibrium(const char* label, const Model& model, const ExternalLoads& loads,
                                const SimulationSettings& device_settings) {
  Simulation device(model, loads, device_settings);
  const State rest = device.state();
  const StepReport report = device.step();
  REQUIRE(report.converged);
  StepPotential probe(model, loads, 1);
  probe.set_equilibrium();
  const double scale = std::max(probe.frame_loads().force_norm(1.0), free_gradient_norm(probe, rest));
  const double bound = 2 * device_settings.newton.tolerance * scale;
  const MinimiserBound b = minimiser_bound(probe, device.state(), device.state());
  std::printf("[%s] newton %d cg %d |g| %.2e (bound %.2e) lambda_min %.3e\n", label, report.newton_iterations,
              report.cg_iterations, b.gradient_a, bound, b.lambda_min);
  CHECK(b.gradient_a <= bound);
  CHECK(b.lambda_min > 0);
  CHECK(max_abs(device.state().velocities) == 0.0);  // a static step ends at rest
  return b.gradient_a / bound;
}

// The models of the comparisons: every force field and the rigid mapping.
enum class Kind { tissue, rigid, coupled, hexahedra };
const char* to_string(Kind k) {
  return k == Kind::tissue ? "tissue" : k == Kind::rigid ? "rigid" : k == Kind::coupled ? "coupled" : "hexahedra";
}

// tissue: a tetrahedral block clamped at x = 0; rigid: the same with its bottom frames attached to
// a free rigid plate under it (the mapped frames of device_rigid.hpp); coupled: a block with a
// shell on its top face sharing its top frames, standing on a fixed rigid plate
// (support/coupling_fixtures.hpp); hexahedra: a block of frame hexahedra clamped at x = 0, whose
// static equilibria carry the rotation stabilisation (device_stabilisation.hpp).
Model test_model(Kind kind) {
  if (kind == Kind::coupled) return coupled_model(CellType::tetrahedron, true);
  if (kind == Kind::tissue || kind == Kind::hexahedra) {
    const CellType cells = kind == Kind::tissue ? CellType::tetrahedron : CellType::hexahedron;
    Model model = small_box_model(cells, MaterialLaw::neo_hookean, 3, 2, 2);
    fix_frames(model, [](double x, double, double) { return x < 1e-9; });
    REQUIRE(RotationStabilisation::applies(model) == (kind == Kind::hexahedra));
    return model;
  }
  ModelBuilder builder;
  const int tissue = builder.add_tissue("tissue", small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 3, 2, 2),
                                        SurfaceMesh{});
  const int plate = builder.add_rigid("plate", box_surface({0, 0, -0.02}, {0.2, 0.1, 0}), 1000.0);
  REQUIRE(builder.attach(tissue, plate, 1e-6) > 0);
  REQUIRE(builder.fix(tissue, [](double x, double, double) { return x < 1e-9; }) > 0);
  return builder.build();
}

// Device array helpers for the comparisons.
struct DeviceArray {
  explicit DeviceArray(size_t n) : size(n) { REQUIRE(cudaMalloc(&data, n * sizeof(double)) == cudaSuccess); }
  ~DeviceArray() { cudaFree(data); }
  void upload(const std::vector<double>& v) {
    REQUIRE(cudaMemcpy(data, v.data(), size * sizeof(double), cudaMemcpyHostToDevice) == cudaSuccess);
  }
  std::vector<double> download() const {
    std::vector<double> v(size);
    REQUIRE(cudaDeviceSynchronize() == cudaSuccess);
    REQUIRE(cudaMemcpy(v.data(), data, size * sizeof(double), cudaMemcpyDeviceToHost) == cudaSuccess);
    return v;
  }
  double* data = nullptr;
  size_t size;
};

double relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (size_t k = 0; k < a.size(); ++k) num += (a[k] - b[k]) * (a[k] - b[k]), den += b[k] * b[k];
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

// Both potentials set alike: a backward-Euler step of 10 ms (Rayleigh mass 0.8, stiffness
// damping beta: the device potential's) from a random start, or a static equilibrium (with the
// rotation stabilisation of frame hexahedra).
void set_step(const Model& model, StepPotential& cpu, DevicePotential& dev, bool dynamic, double beta = 0.0) {
  if (!dynamic) {
    cpu.set_equilibrium();
    dev.set_equilibrium();
    return;
  }
  const State start = random_state(model, 7, 0.002, 0.2, 0.4);
  cpu.set_dynamic(start, 0.01, 0.8, beta);
  dev.set_dynamic(start, 0.01, 0.8);
}

// The step's label in the tests' output: static, dynamic, or dynamic with stiffness damping.
const char* step_label(bool dynamic, double beta) { return !dynamic ? "static" : beta > 0 ? "damped" : "dynamic"; }

}  // namespace

TEST_CASE("device potential equals StepPotential: value, gradient, Hessian product, preconditioner", "[gpu]") {
  const bool dynamic = GENERATE(false, true);
  const double beta = GENERATE(0.0, 0.002);  // stiffness-proportional damping (s), dynamic steps only
  if (!dynamic && beta > 0) return;
  const Kind kind = GENERATE(Kind::tissue, Kind::rigid, Kind::coupled, Kind::hexahedra);
  const Model model = test_model(kind);
  ExternalLoads loads = all_loads(model);
  const double load_scale = 0.7;
  loads.scale = load_scale;
  const State start = random_state(model, 7, 0.002, 0.2, 0.4);
  State start_v = start;
  for (size_t k = 0; k < start_v.velocities.size(); ++k) start_v.velocities[k] = 0.01 * std::sin(1.3 * k);
  State state = random_state(model, 11, 0.004, 0.3, 0.4);
  RigidMapping(model).sync(state);  // attached frames on their body, as every solver state
  const double dt = 0.01, alpha = 0.8;

  StepPotential cpu(model, loads, 1);
  DevicePotential dev(model, loads, {}, beta);
  dev.set_load_scale(load_scale);
  if (dynamic) {
    cpu.set_dynamic(start_v, dt, alpha, beta);
    dev.set_dynamic(start_v, dt, alpha);
  } else {
    cpu.set_equilibrium();
    dev.set_equilibrium();
  }
  const size_t n = static_cast<size_t>(model.dof_count());
  DeviceFrames q = dev.make_state();
  q.upload(state);

  const double v_cpu = cpu.value(state), v_dev = dev.value(q);
  std::vector<double> g_cpu;
  const double phi_cpu = cpu.gradient(state, g_cpu);
  DeviceArray g(n);
  const double phi_dev = dev.gradient(q, g.data);
  std::printf("[device potential %s %s] value %.17g / %.17g, gradient rel. diff %.2e\n", step_label(dynamic, beta),
              to_string(kind), v_cpu, v_dev, relative_difference(g.download(), g_cpu));
  CHECK(std::abs(v_dev - v_cpu) <= 1e-12 * std::abs(v_cpu));
  CHECK(std::abs(phi_dev - phi_cpu) <= 1e-12 * std::abs(phi_cpu));
  CHECK(relative_difference(g.download(), g_cpu) <= 1e-12);

  cpu.prepare_hessian(state);
  dev.prepare_hessian(q);
  const LinearSystem sys = cpu.system();
  std::vector<double> d(n), hd_cpu(n);
  for (size_t k = 0; k < n; ++k) d[k] = 1e-3 * std::cos(0.7 * k);
  sys.apply(d.data(), hd_cpu.data());
  DeviceArray dd(n), hd(n);
  dd.upload(d);
  dev.apply(dd.data, hd.data);
  const std::vector<double> hd_dev = hd.download();
  std::printf("[device potential %s %s] H d rel. diff %.2e\n", step_label(dynamic, beta), to_string(kind),
              relative_difference(hd_dev, hd_cpu));
  CHECK(relative_difference(hd_dev, hd_cpu) <= 1e-12);

  // The preconditioner is the CPU's block Jacobi (solve/block_jacobi.hpp) of the CPU's diagonal
  // blocks: the same inverse per frame, applied to a vector (free: the reduced system's, mapped
  // frames fixed). Bound: 1e-10 relative; the blocks' condition numbers stay below 1e4 here (mass
  // and stiffness of similar scale), so the two Cholesky inverses agree to about 1e4 ulps, and a
  // block that is indefinite falls back to the same inverse absolute diagonal on both sides.
  std::vector<double> blocks(36 * model.frame_count());
  sys.diagonal_blocks(blocks.data());
  const BlockJacobi jacobi(blocks, sys.fixed);
  std::vector<double> z_cpu(n);
  jacobi.apply(d, z_cpu);
  REQUIRE(dev.preconditioner() != nullptr);
  DeviceArray z(n);
  dev.ops().block_apply(dev.preconditioner(), dd.data, z.data, model.frame_count());
  std::vector<double> z_dev = z.download();
  for (size_t k = 0; k < n; ++k)
    if (sys.fixed[k]) z_dev[k] = z_cpu[k] = 0;  // PCG projects z (solve/pcg.hpp)
  std::printf("[device potential %s %s] preconditioner rel. diff %.2e\n", step_label(dynamic, beta),
              to_string(kind), relative_difference(z_dev, z_cpu));
  CHECK(relative_difference(z_dev, z_cpu) <= 1e-10);

  // The elastic energy (a step's report) at the state of the last force pass, after the tangent
  // products: the pass is skipped and its energy stands (DeviceElasticity::gradient_on_device);
  // at another state, and back, a new pass's. The same bound as the value's.
  State other = random_state(model, 13, 0.004, 0.3, 0.4);
  RigidMapping(model).sync(other);
  DeviceFrames q_other = dev.make_state();
  q_other.upload(other);
  const double e_cpu = cpu.elastic_energy(state), e_other_cpu = cpu.elastic_energy(other);
  const double e_dev = dev.elastic_energy(q), e_other_dev = dev.elastic_energy(q_other), e_back = dev.elastic_energy(q);
  std::printf("[device potential %s %s] elastic energy %.17g / %.17g, at another state %.17g / %.17g\n",
              step_label(dynamic, beta), to_string(kind), e_cpu, e_dev, e_other_cpu, e_other_dev);
  REQUIRE(std::abs(e_other_cpu - e_cpu) > 1e-6 * std::abs(e_cpu));
  CHECK(std::abs(e_dev - e_cpu) <= 1e-12 * std::abs(e_cpu));
  CHECK(std::abs(e_other_dev - e_other_cpu) <= 1e-12 * std::abs(e_other_cpu));
  CHECK(e_back == e_dev);
}

TEST_CASE("device tangent blocks equal the CPU's assembled step tangent between frames that are not bodies", "[gpu]") {
  const Kind kind = GENERATE(Kind::tissue, Kind::rigid, Kind::coupled, Kind::hexahedra);
  const bool dynamic = GENERATE(false, true);
  const double beta = GENERATE(0.0, 0.002);
  if (!dynamic && beta > 0) return;
  const Model model = test_model(kind);
  const ExternalLoads loads = all_loads(model);
  StepPotential cpu(model, loads, 1);
  DevicePotential dev(model, loads, {}, beta);
  set_step(model, cpu, dev, dynamic, beta);
  State state = random_state(model, 11, 0.001, 0.1, 0.4);
  RigidMapping(model).sync(state);
  DeviceFrames q = dev.make_state();
  q.upload(state);
  cpu.prepare_hessian(state);
  dev.prepare_hessian(q);
  const TangentProbing t = tangent_probing(model);
  dev.set_tangent_blocks(t.block_offsets, t.block_frames, t.diagonal_blocks);
  DeviceArray blocks(36 * t.block_frames.size());
  dev.tangent_blocks(blocks.data);
  const std::vector<double> got = blocks.download();
  const LinearSystem sys = cpu.system();
  const Eigen::MatrixXd H(sys.assemble());
  // Between frames that are not bodies a block is all of H there: the same per-sample, per-triangle
  // and per-frame terms summed in another order, to rounding (1e-12 of the largest). The blocks
  // (f, g) with g > f (the transposes of (g, f)) are not formed: zero.
  auto body = [&](int f) { return std::binary_search(t.bodies.begin(), t.bodies.end(), f); };
  std::vector<double> a, b;
  int upper = 0;
  for (int f = 0; f < t.frames; ++f)
    for (int p = t.block_offsets[static_cast<size_t>(f)]; p < t.block_offsets[static_cast<size_t>(f) + 1]; ++p) {
      const int g = t.block_frames[static_cast<size_t>(p)];
      if (g > f) {
        ++upper;
        for (int e = 0; e < 36; ++e) REQUIRE(got[36 * static_cast<size_t>(p) + static_cast<size_t>(e)] == 0.0);
      }
      if (g > f || body(f) || body(g)) continue;
      for (int e = 0; e < 36; ++e) {
        const int i = 6 * f + e / 6, j = 6 * g + e % 6;
        if (sys.fixed[i] || sys.fixed[j]) continue;
        a.push_back(got[36 * static_cast<size_t>(p) + static_cast<size_t>(e)]);
        b.push_back(H(i, j));
      }
    }
  REQUIRE(!a.empty());
  REQUIRE(upper > 0);
  std::printf("[tangent blocks %s %s] %zu blocks, %zu bodies, rel. diff %.2e\n", step_label(dynamic, beta),
              to_string(kind), t.block_frames.size(), t.bodies.size(), relative_difference(a, b));
  CHECK(relative_difference(a, b) <= 1e-12);
}

TEST_CASE("device Cholesky factor solves the step tangent as CHOLMOD does", "[gpu]") {
  const bool dynamic = GENERATE(false, true);
  // The test models, and a tissue block clamped at x = 0 of more than twice the factor's largest
  // diagonal block in DOFs, which its inversion splits at two levels.
  const int which = GENERATE(0, 1, 2, 3);
  const Kind kind = which == 3 ? Kind::tissue : std::array{Kind::tissue, Kind::rigid, Kind::coupled}[which];
  const Model model = which < 3 ? test_model(kind) : [] {
    Model m = small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 12, 8, 6);
    fix_frames(m, [](double x, double, double) { return x < 1e-9; });
    return m;
  }();
  if (which == 3) REQUIRE(model.dof_count() > 2 * DeviceCholesky::kDiagonalBlock);
  const ExternalLoads loads = all_loads(model);
  StepPotential cpu(model, loads, 1);
  DevicePotential dev(model, loads);
  set_step(model, cpu, dev, dynamic);
  DeviceCholesky factor(dev);
  DeviceFrames q = dev.make_state();
  // Two states: the kept factor, refactorised at the second, must solve with that state's tangent
  // (the large block: one state, its bound's n solves with CHOLMOD being the test's cost).
  for (const int seed : {11, 13}) {
    if (which == 3 && seed != 11) continue;
    State state = random_state(model, seed, 0.001, 0.1, 0.4);
    RigidMapping(model).sync(state);
    q.upload(state);
    cpu.prepare_hessian(state);
    dev.prepare_hessian(q);
    const LinearSystem sys = cpu.system();
    SparseCholesky cholmod;
    REQUIRE(cholmod.factorise(sys.assemble(), sys.fixed));
    const LinearResult f = factor.factorise(dev);
    REQUIRE(factor.factorised());
    // Both factorise the same matrix or neither shifts it.
    REQUIRE(f.shifted == (cholmod.shift() > 0));
    const size_t n = static_cast<size_t>(model.dof_count());
    std::vector<double> r(n), z_cpu;
    for (size_t k = 0; k < n; ++k) r[k] = sys.fixed[k] ? 0.0 : std::cos(0.37 * k);
    cholmod.solve(r, z_cpu);
    DeviceArray rd(n), zd(n);
    rd.upload(r);
    factor.solve(rd.data, zd.data);
    const std::vector<double> z_dev = zd.download();
    // Bound, per DOF i: the device applies H^{-1} rounded to float (u = 2^-24 per entry) to r
    // rounded to float, summing n products in float (at most n roundings), so
    //   |z_dev - z|_i <= (n + 2) u (|H^{-1}| |r|)_i  (first order; Higham, Accuracy and
    // Stability, 3.1), with |H^{-1}| from CHOLMOD's solves with the unit vectors. The two double
    // inverses differ by the rounding of their factorisations, about cond(H) 1e-16 relative; the
    // models' tangents here have cond(H) below 1e6 (the backward-Euler ones far below: mass over
    // h^2 dominates), hence 1e-9 of |z|'s largest entry on top.
    std::vector<double> bound(n, 0.0), unit(n, 0.0), column;
    for (size_t j = 0; j < n; ++j) {
      if (sys.fixed[j] || r[j] == 0.0) continue;
      unit[j] = 1.0;
      cholmod.solve(unit, column);
      unit[j] = 0.0;
      for (size_t i = 0; i < n; ++i) bound[i] += std::abs(column[i] * r[j]);
    }
    const double u = std::ldexp(1.0, -24), largest = *std::max_element(z_cpu.begin(), z_cpu.end(), [](double a, double b) {
      return std::abs(a) < std::abs(b);
    });
    double worst = 0;  // the largest difference over its bound
    for (size_t i = 0; i < n; ++i)
      worst = std::max(worst, std::abs(z_dev[i] - z_cpu[i]) / ((n + 2) * u * bound[i] + 1e-9 * std::abs(largest)));
    std::printf("[device Cholesky %s %s, %d DOFs, state %d] %d products, %s, solve rel. diff %.2e, %.2e of the bound\n",
                dynamic ? "dynamic" : "static", to_string(kind), model.dof_count(), seed, factor.products(),
                f.shifted ? "shifted" : "not shifted", relative_difference(z_dev, z_cpu), worst);
    CHECK(worst <= 1.0);
  }
}

// The device step against the CPU engine's step in its definition: StepPotential (backward Euler
// with Rayleigh mass damping, gravity on the samples, a point force) minimised by one Newton
// iteration with 60 fixed CG or block-Jacobi PCG iterations, as `fascia bench cpu` and `bench gpu`
// time it, then v = Delta / h.
TEST_CASE("the benchmark step on the device equals the CPU engine's one-iteration Newton step", "[gpu]") {
  const LinearMethod method = GENERATE(LinearMethod::pcg, LinearMethod::cg);
  const double alpha = GENERATE(0.0, 0.5);
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 4, 3, 2);
  State start = random_state(model, 41, 0.004, 0.2, 0.7);
  const double h = 0.01;
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  loads.point_forces.push_back(PointForce{model.frame_count() - 1, Vec3{0.3, -0.2, 0.1}});
  SimulationSettings settings;
  settings.dt = h;
  settings.rayleigh_mass = alpha;
  settings.newton.fixed_iterations = 1;
  settings.newton.linear.method = method;
  settings.newton.linear.preconditioner = Preconditioner::block_jacobi;
  settings.newton.linear.fixed_iterations = true;
  settings.newton.linear.max_iterations = 60;

  StepPotential potential(model, loads, 1);
  potential.set_dynamic(start, h, alpha, 0.0);
  State cpu = start;
  const NewtonResult r = minimise(potential, cpu, settings.newton, 0.0);
  std::vector<double> delta;
  potential.increments(cpu, delta);
  cpu.velocities = delta;
  for (double& v : cpu.velocities) v /= h;

  std::string why;
  const std::unique_ptr<StepBackend> step = cuda_step_factory()(model, loads, settings, why);
  REQUIRE(step);
  State gpu = start;
  const NewtonResult rg = step->backward_euler(start, gpu, h, alpha, settings.newton, 0.0);

  const double e_pos = relative_difference(gpu.positions, cpu.positions);
  const double e_rot = relative_difference(gpu.orientations, cpu.orientations);
  const double e_vel = relative_difference(gpu.velocities, cpu.velocities);
  std::printf("[gpu] benchmark step %s alpha=%g: cg %d (cpu %d) positions %.2e orientations %.2e velocities %.2e\n",
              to_string(method), alpha, rg.cg_iterations, r.cg_iterations, e_pos, e_rot, e_vel);
  CHECK(rg.cg_iterations == r.cg_iterations);
  // PCG: the same operator, right-hand side and preconditioner give the same step to round-off.
  // Plain CG: 60 iterations far from convergence on H, whose translational (m/h^2) and rotational
  // (I/h^2) scales differ by orders of magnitude, amplify the round-off of different summation
  // orders (1e-6 to 2.5e-4 relative on an H200); the PCG cases check the definition, this bound
  // checks that CG solves the same system.
  const double tol = method == LinearMethod::pcg ? 1e-12 : 1e-3;
  CHECK(e_pos < tol);
  CHECK(e_rot < tol);
  CHECK(e_vel < tol);
}

TEST_CASE("whole step on the device equals the CPU engine on a tissue block", "[gpu]") {
  const Integrator integrator = GENERATE(Integrator::backward_euler, Integrator::static_equilibrium);
  // cg, pcg with block Jacobi, pcg with the kept factorisation, a factorisation per Newton iteration.
  const int solver = GENERATE(0, 1, 2, 3);
  const LinearMethod method = solver == 0 ? LinearMethod::cg : solver == 3 ? LinearMethod::cholmod : LinearMethod::pcg;
  const Kind kind = GENERATE(Kind::tissue, Kind::rigid, Kind::coupled, Kind::hexahedra);
  // Stiffness-proportional damping (s): backward Euler only.
  const double beta = GENERATE(0.0, 0.002);
  if (integrator != Integrator::backward_euler && beta > 0) return;
  const Model model = test_model(kind);
  const ExternalLoads loads = all_loads(model);
  SimulationSettings s;
  s.integrator = integrator;
  s.dt = 0.01;
  s.rayleigh_mass = 0.5;
  s.rayleigh_stiffness = beta;
  s.newton.tolerance = 1e-10;
  s.newton.linear.method = method;
  s.newton.linear.preconditioner = solver == 1 ? Preconditioner::block_jacobi : Preconditioner::cholmod;
  s.newton.linear.tolerance = 1e-10;
  SimulationSettings device = s;
  device.step_backend = cuda_step_factory();
  {
    Simulation probe(model, loads, device);
    REQUIRE(probe.on_step_backend());
  }
  char label[80];
  std::snprintf(label, sizeof label, "device step %s%s %s %s %s", to_string(integrator), beta > 0 ? " damped" : "",
                to_string(method), to_string(s.newton.linear.preconditioner), to_string(kind));
  if (integrator == Integrator::static_equilibrium && kind == Kind::hexahedra)
    CHECK(check_device_equilibrium(label, model, loads, device) <= 1.0);  // one of several minima
  else
    CHECK(check_backends_agree(label, model, loads, s, device, 3) <= 1.0);
}

TEST_CASE("the variational step on the device solves the CPU's discrete Euler-Lagrange equations", "[gpu]") {
  // A solution of (4) is not a minimiser (variational_step.hpp), so the device's states are checked
  // against the CPU's equations rather than the CPU's states: the CPU's residual of (4) at the
  // device's q_{k+1} is within the Newton tolerance, and the device's velocities are the CPU's
  // (5) at that q_{k+1}.
  const int solver = GENERATE(0, 1, 2, 3);  // cg, pcg + block Jacobi, pcg + kept factor, cholmod
  const LinearMethod method = solver == 0 ? LinearMethod::cg : solver == 3 ? LinearMethod::cholmod : LinearMethod::pcg;
  const Kind kind = GENERATE(Kind::tissue, Kind::rigid, Kind::coupled, Kind::hexahedra);
  const Model model = test_model(kind);
  const ExternalLoads loads = all_loads(model);
  SimulationSettings s;
  s.integrator = Integrator::variational;
  s.dt = 0.01;
  s.newton.tolerance = 1e-8;
  s.newton.linear.method = method;
  s.newton.linear.preconditioner = solver == 1 ? Preconditioner::block_jacobi : Preconditioner::cholmod;
  s.newton.linear.tolerance = 1e-10;
  s.step_backend = cuda_step_factory();
  Simulation device(model, loads, s);
  REQUIRE(device.on_step_backend());
  // A spin of 2 rad/s about z and a drift on the free DOFs: rotations of about 1 degree per step.
  {
    State& q = device.state();
    const Vec3 w{0.3, -0.4, 2.0}, v{0.05, 0.02, -0.01};
    for (int i = 0; i < model.frame_count(); ++i) {
      const Vec3 vi = v + cross(w, load3(&q.positions[3 * i]));
      for (int k = 0; k < 3; ++k) {
        q.velocities[6 * i + k] = model.fixed_dofs[6 * i + k] ? 0.0 : (&vi.x)[k];
        q.velocities[6 * i + 3 + k] = model.fixed_dofs[6 * i + 3 + k] ? 0.0 : (&w.x)[k];
      }
    }
  }
  StepPotential potential(model, loads, 1);
  VariationalStep cpu(model, potential, s.dt);
  const double reference = potential.frame_loads().force_norm(1.0);
  for (int k = 1; k <= 3; ++k) {
    const State start = device.state();
    const StepReport report = device.step();
    REQUIRE(report.converged);
    const State& end = device.state();
    // The CPU's own step from the same start gives the residual's force scale S (N).
    State cpu_end = start;
    const NewtonResult rc = cpu.advance(start, cpu_end, s.newton, reference);
    REQUIRE(rc.converged());
    const double scale = cpu.residual_scale();
    std::vector<double> p_start, r, minus_d1, p_end;
    cpu.momenta(start, p_start);
    const double residual = cpu.residual(start, end, p_start, r);
    // Converged on the device: |r / h| <= tolerance S there. The CPU evaluates r with V's
    // gradient summed in another order, a relative 1e-14 of its terms, far below the tolerance's
    // 1e-8: twice the tolerance bounds the CPU's value.
    const double bound = 2 * s.newton.tolerance * scale * s.dt;
    // Velocities: (5) at the device's state on the CPU, then the same 6 x 6 mass solves. They
    // differ by the round-off of g (above) through h A^T g, relative 1e-12 at most of the largest.
    cpu.action_derivatives(start, end, minus_d1, p_end);
    State expected = end;
    cpu.set_velocities(start, expected, p_end);
    double v_max = 0, v_diff = 0;
    for (size_t i = 0; i < end.velocities.size(); ++i) {
      v_max = std::max(v_max, std::abs(expected.velocities[i]));
      v_diff = std::max(v_diff, std::abs(end.velocities[i] - expected.velocities[i]));
    }
    const StateDifference d = max_difference(end, cpu_end);
    std::printf("[gpu] variational %s %s %s step %d: newton %d/%d cg %d/%d |r| %.2e (bound %.2e) velocity %.2e "
                "(of %.2e) | state vs CPU: position %.2e rotation %.2e\n",
                to_string(method), to_string(s.newton.linear.preconditioner), to_string(kind), k, rc.iterations,
                report.newton_iterations, rc.cg_iterations, report.cg_iterations, residual, bound, v_diff, v_max,
                d.position, d.rotation);
    CHECK(residual <= bound);
    CHECK(v_diff <= 1e-12 * v_max);
  }
}

TEST_CASE("Newton-Krylov directions on the device: the coupling scene undamped at 20 ms", "[gpu]") {
  // scenes/coupling.yaml at twice its dt without damping: at step 4 the iteration matrix's
  // directions stop decreasing |r| and Newton continues along Newton-Krylov ones (solve/newton.hpp,
  // over the device's vectors). Checked as above: the CPU's residual of (4) at each of the
  // device's states.
  const std::string dir = std::filesystem::is_directory("scenes") ? "scenes" : std::string(FASCIA_SOURCE_DIR) + "/scenes";
  dsl::BuiltScene b = dsl::build_scene(dsl::parse_scene(
      dir + "/coupling.yaml",
      {"solver.integrator=variational", "solver.rayleigh_mass=0", "solver.dt=20ms", "run.duration=0.1s"}));
  b.settings.threads = 1;
  SimulationSettings s = b.settings;
  s.step_backend = cuda_step_factory();
  Simulation device(b.model, b.loads, s, b.motions);
  REQUIRE(device.on_step_backend());
  Simulation host(b.model, b.loads, b.settings, b.motions);
  StepPotential potential(host.model(), host.loads(), 1);
  VariationalStep cpu(host.model(), potential, s.dt);
  const double reference = potential.frame_loads().force_norm(1.0);
  for (int k = 1; k <= b.steps; ++k) {
    const State start = device.state();
    const StepReport report = device.step();
    INFO("step " << k << ": " << report.message);
    REQUIRE(report.converged);
    State cpu_end = start;
    cpu.advance(start, cpu_end, s.newton, reference);  // the force scale S of the step
    std::vector<double> p_start, r;
    cpu.momenta(start, p_start);
    const double residual = cpu.residual(start, device.state(), p_start, r);
    const double bound = 2 * s.newton.tolerance * cpu.residual_scale() * s.dt;
    std::printf("[gpu] coupling.yaml variational 20 ms step %d: newton %d cg %d |r| %.2e (bound %.2e)\n", k,
                report.newton_iterations, report.cg_iterations, residual, bound);
    CHECK(residual <= bound);
  }
}

namespace {

// Each shipped scene's first `steps` steps (static scenes: one full solve each) on the device with
// `options` against the CPU engine, each step from the CPU's state, within the a-posteriori bound
// of Newton's tolerance.
void check_shipped_scenes(const DeviceOptions& options, int steps) {
  // The scenes of the working directory's checkout where there is one (the GPU machine runs the
  // tests from a checkout other than the build's), else of the source tree.
  const std::string dir = std::filesystem::is_directory("scenes") ? "scenes" : std::string(FASCIA_SOURCE_DIR) + "/scenes";
  std::vector<std::string> scenes;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") scenes.push_back(entry.path().string());
  std::sort(scenes.begin(), scenes.end());
  REQUIRE(!scenes.empty());
  for (const std::string& path : scenes) {
    const dsl::BuiltScene built = dsl::build_scene(dsl::parse_scene(path));
    // Backends are compared in lockstep over fixed steps. An adaptive scene's first dt may be one
    // that fails by design (scenes/tool_strike.yaml inverts elements at 10 ms and is resolved by
    // rejections), so its steps are compared at 0.1 ms, within the range its controller takes
    // (docs/solvers.md).
    SimulationSettings cpu = built.settings;
    if (cpu.adaptive.enabled) {
      cpu.adaptive.enabled = false;
      cpu.dt = 1e-4;
    }
    SimulationSettings device = cpu;
    device.elasticity = cuda_elasticity_factory(options);
    device.step_backend = cuda_step_factory(options);
    bool whole = false;
    {
      Simulation probe(built.model, built.loads, device, built.motions);
      whole = probe.on_step_backend();
      std::printf("[%s, %s] %s%s\n", path.c_str(), to_string(options.precision),
                  whole ? "whole step on the device" : "CPU step, elasticity on the device: ",
                  whole ? "" : probe.step_backend_refusal().c_str());
    }
    CHECK(check_backends_agree(path.c_str(), built.model, built.loads, cpu, device, std::min(steps, built.steps),
                               built.motions) <= 1.0);
  }
}

}  // namespace

TEST_CASE("every shipped scene: --backend cuda equals the CPU engine", "[gpu]") {
  check_shipped_scenes(DeviceOptions{}, 3);
}

TEST_CASE("every shipped scene in single precision converges at its own Newton tolerance", "[gpu]") {
  // Single storage holds the tangent; the forces and energies, which Newton's tolerance and line
  // search judge, are evaluated in double (kernels/device_potential.cu), so the scenes' tolerance
  // of 1e-6 is reached as in double (with float forces the residual stalls at 1e-5 to 1e-4).
  DeviceOptions options;
  options.precision = Precision::single_precision;
  check_shipped_scenes(options, 2);
}
