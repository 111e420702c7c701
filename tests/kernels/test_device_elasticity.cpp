// The CUDA backend against the CPU reference (fascia::Elasticity and the host PCG of
// reference_step.hpp): energy, forces, tangent products, diagonal blocks and a full Newton step,
// for the three laws (hgo with a fibre direction per sample: one family coupled, two uncoupled), both storage precisions, the grouped and the coalesced tangent pass, and the
// resident, two-barrier and launched PCG; and bitwise-identical repeated runs.
//
// Bounds. Double: 1e-12 relative (norm-wise); the device sums in other orders than the CPU, so
// results agree to a few ulps times the conditioning of the sums, far below 1e-12. Single: the
// model tables, frame kinematics and vectors are stored in float (unit roundoff 6e-8); strains of
// a few percent come from differences of O(1) terms, so the relative error of forces is bounded
// by about 1e-4 (measured values are printed), and 1e-3 for a step after 60 PCG iterations.
#include "device_elasticity.hpp"
#include "device_step.hpp"
#include "integrate/step_potential.hpp"
#include "reference_step.hpp"
#include "sample_layout.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <numeric>
#include <string>

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

namespace {

// The test models: a box of tetrahedra or hexahedra (mesh-based: groups of samples share their
// frames, so the tangent product runs the grouped pass), or the box of tetrahedra with one sample
// per frame set (every group one sample: the coalesced pass).
enum class Shape { tetrahedra, hexahedra, single_samples };

struct Case {
  Precision precision;
  Shape shape;
  MaterialLaw law;
  HgoVariant hgo = HgoVariant::one_family_coupled;  // law hgo only
};

std::string law_name(const Case& c) {
  return c.law == MaterialLaw::hgo ? std::string("hgo (") + to_string(c.hgo) + ")" : std::string(to_string(c.law));
}

double bound(Precision p, bool step) {
  if (p == Precision::double_precision) return 1e-12;
  return step ? 1e-3 : 1e-4;
}

const char* name(Shape s) {
  return s == Shape::tetrahedra ? "tet" : s == Shape::hexahedra ? "hex" : "tet, one sample per frame set";
}

// The model's first sample of each frame set only (reorder_samples with a subset of the samples).
Model single_samples(const Model& model) {
  std::vector<int> order;
  std::vector<std::vector<int>> seen;
  const NeighbourTable& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s) {
    std::vector<int> f(nb.frames.begin() + nb.offsets[s], nb.frames.begin() + nb.offsets[s + 1]);
    std::sort(f.begin(), f.end());
    if (std::find(seen.begin(), seen.end(), f) == seen.end()) {
      seen.push_back(f);
      order.push_back(s);
    }
  }
  return reorder_samples(model, order);
}

Model test_model(Shape shape, MaterialLaw law, int nx = 4, int ny = 3, int nz = 2,
                 HgoVariant hgo = HgoVariant::one_family_coupled) {
  const Model box = kernels_test_model(shape == Shape::hexahedra ? CellType::hexahedron : CellType::tetrahedron, law,
                                       nx, ny, nz, hgo);
  return shape == Shape::single_samples ? single_samples(box) : box;
}

std::vector<double> random_vector(int dofs, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> d(dofs);
  for (int j = 0; j < dofs; ++j) d[j] = (j % 6 < 3 ? 0.01 : 1.0) * u(rng);
  return d;
}

}  // namespace

TEST_CASE("device forces, tangent products and diagonal blocks equal the CPU reference", "[gpu]") {
  const Case c = GENERATE(Case{Precision::double_precision, Shape::tetrahedra, MaterialLaw::stvk},
                          Case{Precision::double_precision, Shape::hexahedra, MaterialLaw::stvk},
                          Case{Precision::double_precision, Shape::hexahedra, MaterialLaw::neo_hookean},
                          Case{Precision::double_precision, Shape::single_samples, MaterialLaw::neo_hookean},
                          Case{Precision::double_precision, Shape::tetrahedra, MaterialLaw::hgo},
                          Case{Precision::double_precision, Shape::hexahedra, MaterialLaw::hgo},
                          Case{Precision::double_precision, Shape::single_samples, MaterialLaw::hgo},
                          Case{Precision::single_precision, Shape::tetrahedra, MaterialLaw::stvk},
                          Case{Precision::single_precision, Shape::hexahedra, MaterialLaw::neo_hookean},
                          Case{Precision::single_precision, Shape::hexahedra, MaterialLaw::hgo},
                          Case{Precision::double_precision, Shape::tetrahedra, MaterialLaw::hgo,
                               HgoVariant::two_families_uncoupled},
                          Case{Precision::double_precision, Shape::hexahedra, MaterialLaw::hgo,
                               HgoVariant::two_families_uncoupled},
                          Case{Precision::double_precision, Shape::single_samples, MaterialLaw::hgo,
                               HgoVariant::two_families_uncoupled},
                          Case{Precision::single_precision, Shape::hexahedra, MaterialLaw::hgo,
                               HgoVariant::two_families_uncoupled},
                          Case{Precision::single_precision, Shape::single_samples, MaterialLaw::stvk});
  const Model model = test_model(c.shape, c.law, 4, 3, 2, c.hgo);
  const State state = kernels_test_state(model, 21);
  const int dofs = model.dof_count(), n = model.frame_count();

  Elasticity cpu(model, 1);
  std::vector<double> g(dofs), Kd(dofs), blocks(36 * n);
  const double w = cpu.gradient(state, g.data());
  cpu.prepare(state);
  cpu.tangent_diagonal_blocks(blocks.data());
  const std::vector<double> d = random_vector(dofs, 4);
  cpu.apply_tangent(d.data(), Kd.data());

  DeviceOptions options;
  options.precision = c.precision;
  DeviceElasticity dev(model, options);
  INFO(dev.group_samples_refusal());
  CHECK(dev.group_samples() == (c.shape != Shape::single_samples));
  dev.set_state(state);
  std::vector<double> dg(dofs), dKd(dofs), dblocks(36 * n);
  const double dw = dev.gradient(dg.data());
  const double dw2 = dev.prepare();
  dev.tangent_diagonal_blocks(dblocks.data());
  dev.apply_tangent(d.data(), dKd.data());

  const double e_energy = std::abs(dw - w) / std::abs(w), e_grad = relative_difference(dg, g),
               e_tangent = relative_difference(dKd, Kd), e_blocks = relative_difference(dblocks, blocks);
  std::printf("[gpu] %s %s %s (%s pass): energy %.2e gradient %.2e tangent %.2e blocks %.2e\n", to_string(c.precision),
              name(c.shape), law_name(c).c_str(), dev.group_samples() ? "grouped" : "coalesced", e_energy, e_grad,
              e_tangent, e_blocks);
  const double tol = bound(c.precision, false);
  CHECK(e_energy < tol);
  CHECK(dw2 == dw);
  CHECK(e_grad < tol);
  CHECK(e_tangent < tol);
  CHECK(e_blocks < tol);
}

TEST_CASE("device backward-Euler Newton step equals the CPU reference", "[gpu]") {
  // Persistent: the resident kernel in single precision and in double for 4 pairs per sample
  // (with its blocks' frames staged in shared memory), k_pcg_two_barrier in double for 8;
  // launched: the grouped or the coalesced tangent pass.
  const Case c = GENERATE(Case{Precision::double_precision, Shape::tetrahedra, MaterialLaw::stvk},
                          Case{Precision::double_precision, Shape::hexahedra, MaterialLaw::neo_hookean},
                          Case{Precision::double_precision, Shape::single_samples, MaterialLaw::stvk},
                          Case{Precision::double_precision, Shape::tetrahedra, MaterialLaw::hgo},
                          Case{Precision::double_precision, Shape::hexahedra, MaterialLaw::hgo},
                          Case{Precision::single_precision, Shape::tetrahedra, MaterialLaw::stvk},
                          Case{Precision::single_precision, Shape::hexahedra, MaterialLaw::neo_hookean},
                          Case{Precision::single_precision, Shape::tetrahedra, MaterialLaw::hgo},
                          Case{Precision::double_precision, Shape::tetrahedra, MaterialLaw::hgo,
                               HgoVariant::two_families_uncoupled},
                          Case{Precision::single_precision, Shape::hexahedra, MaterialLaw::hgo,
                               HgoVariant::two_families_uncoupled},
                          Case{Precision::single_precision, Shape::single_samples, MaterialLaw::neo_hookean});
  const bool persistent = GENERATE(true, false);
  const Model model = test_model(c.shape, c.law, 4, 3, 2, c.hgo);
  const State state = kernels_test_state(model, 33);
  const double h = 0.01;
  const std::vector<double> loads = kernels_test_loads(model);
  const ReferenceStep ref = reference_step(model, state, h, 60, loads);

  DeviceOptions options;
  options.precision = c.precision;
  DeviceElasticity dev(model, options);
  dev.set_state(state);
  StepOptions so;
  so.dt = h;
  so.max_cg_iterations = 60;
  so.persistent = persistent;
  so.external_forces = loads;
  DeviceBackwardEuler stepper(dev, so);
  const StepReport report = stepper.step();
  CHECK(report.persistent == persistent);
  if (persistent)
    // The resident kernel serves models without fibres (k_pcg_resident).
    CHECK(report.resident == (c.law != MaterialLaw::hgo &&
                              (c.precision == Precision::single_precision || c.shape != Shape::hexahedra)));
  std::vector<double> delta(model.dof_count());
  stepper.last_increment(delta.data());
  State after;
  dev.get_state(after);
  State expected = state;
  retract(model, expected, ref.delta.data());
  std::vector<double> v_expected(ref.delta);
  for (double& v : v_expected) v /= h;

  const double e_delta = relative_difference(delta, ref.delta);
  const double e_pos = relative_difference(after.positions, expected.positions);
  const double e_vel = relative_difference(after.velocities, v_expected);
  std::printf("[gpu] step %s %s %s, %s: cg %d (cpu %d) delta %.2e positions %.2e velocities %.2e\n",
              to_string(c.precision), name(c.shape), law_name(c).c_str(),
              report.resident ? "resident" : report.persistent ? "two-barrier" : "launched", report.cg_iterations,
              ref.iterations, e_delta, e_pos, e_vel);
  CHECK(report.cg_iterations == ref.iterations);
  const double tol = bound(c.precision, true);
  CHECK(e_delta < tol);
  CHECK(e_pos < tol);
  CHECK(e_vel < tol);
}

TEST_CASE("launched row passes and reductions that span several chunks equal the CPU reference", "[gpu]") {
  // 17 x 16 x 16 hexahedra, 34,816 samples: the force pass runs 272 blocks, so its energy sums per
  // chunk of 256 blocks (LaunchGrids::reduce_chunk), then over the chunks; 5,202 frames. The row
  // passes loop over their work in at most 3 blocks (limit_row_blocks): 41 blocks of frames and
  // 124 chunks of frame rows. Cells of 3.1 to 12 mm, positions perturbed by at most 0.5 mm (16 %
  // of the thinnest cell, as the 4 x 3 x 2-cell box's 4 mm of its 5 cm), no cell inverted.
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(CellType::hexahedron, MaterialLaw::neo_hookean, 17, 16, 16);
  const State state = kernels_test_state(model, 47, 5e-4);
  const double h = 0.01;
  const std::vector<double> loads = kernels_test_loads(model);
  const ReferenceStep ref = reference_step(model, state, h, 60, loads);
  Elasticity cpu(model, 1);
  std::vector<double> g(model.dof_count()), dg(model.dof_count());
  const double w = cpu.gradient(state, g.data());

  DeviceOptions options;
  options.precision = precision;
  DeviceElasticity dev(model, options);
  REQUIRE(dev.group_samples());
  dev.limit_row_blocks(3);
  const LaunchGrids grids = dev.launch_grids();
  std::printf("[gpu] row passes: %d and %d blocks of work in %d and %d blocks\n", grids.frame_work,
              grids.update_work, grids.frame_grid, grids.update_grid);
  CHECK(grids.frame_grid < grids.frame_work);
  CHECK(grids.update_grid < grids.update_work);
  CHECK(model.sample_count() > 128 * grids.reduce_chunk);  // the force pass's 128-sample blocks
  dev.set_state(state);
  const double dw = dev.gradient(dg.data());
  StepOptions so;
  so.dt = h;
  so.max_cg_iterations = 60;
  so.persistent = false;
  so.external_forces = loads;
  DeviceBackwardEuler stepper(dev, so);
  const StepReport report = stepper.step();
  CHECK_FALSE(report.persistent);
  CHECK(report.cg_iterations == ref.iterations);
  std::vector<double> delta(model.dof_count());
  stepper.last_increment(delta.data());
  const double e_energy = std::abs(dw - w) / std::abs(w), e_grad = relative_difference(dg, g),
               e_delta = relative_difference(delta, ref.delta);
  std::printf("[gpu] launched, %d samples, %s: energy %.2e gradient %.2e cg %d delta %.2e\n", model.sample_count(),
              to_string(precision), e_energy, e_grad, report.cg_iterations, e_delta);
  CHECK(e_energy < bound(precision, false));
  CHECK(e_grad < bound(precision, false));
  CHECK(e_delta < bound(precision, true));
}

TEST_CASE("the grouped pass is refused where samples share no frames", "[gpu]") {
  // One sample per frame set: every group holds one sample, below the 2 the pass needs; the
  // coalesced pass runs instead, and says why.
  const Model model = test_model(Shape::single_samples, MaterialLaw::stvk);
  REQUIRE(model.sample_count() < kernels_test_model(CellType::tetrahedron, MaterialLaw::stvk).sample_count());
  DeviceElasticity dev(model);
  CHECK_FALSE(dev.group_samples());
  CHECK(dev.group_samples_refusal().find("average 1.00 samples") != std::string::npos);
}

// The device step against the CPU engine itself: StepPotential (backward Euler with Rayleigh
// damping, gravity on the samples) minimised by one Newton iteration with 60 fixed CG or PCG
// iterations, as `fascia bench cpu` times it, then v = Delta / h.
TEST_CASE("device step equals the CPU engine's one-iteration Newton step", "[gpu]") {
  const LinearMethod method = GENERATE(LinearMethod::pcg, LinearMethod::cg);
  const double alpha = GENERATE(0.0, 0.5);
  const double beta = alpha > 0 ? 0.002 : 0.0;
  const Model model = kernels_test_model(CellType::hexahedron, MaterialLaw::neo_hookean);
  const State start = kernels_test_state(model, 41);
  const double h = 0.01;
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  loads.point_forces.push_back(PointForce{model.frame_count() - 1, Vec3{0.3, -0.2, 0.1}});
  NewtonSettings newton;
  newton.fixed_iterations = 1;
  newton.linear.method = method;
  newton.linear.preconditioner = Preconditioner::block_jacobi;  // the device's preconditioner
  newton.linear.fixed_iterations = true;
  newton.linear.max_iterations = 60;

  StepPotential potential(model, loads, 1);
  potential.set_dynamic(start, h, alpha, beta);
  State cpu = start;
  const NewtonResult r = minimise(potential, cpu, newton, 0.0);
  std::vector<double> delta;
  potential.increments(cpu, delta);
  cpu.velocities = delta;
  for (double& v : cpu.velocities) v /= h;

  DeviceImplicitStep device(model);
  State gpu = start;
  const StepReport report = device.step(gpu, loads, h, alpha, beta, newton.linear);

  const double e_pos = relative_difference(gpu.positions, cpu.positions);
  const double e_rot = relative_difference(gpu.orientations, cpu.orientations);
  const double e_vel = relative_difference(gpu.velocities, cpu.velocities);
  std::printf("[gpu] engine step %s alpha=%g: cg %d (cpu %d) positions %.2e orientations %.2e velocities %.2e\n",
              to_string(method), alpha, report.cg_iterations, r.cg_iterations, e_pos, e_rot, e_vel);
  CHECK(report.cg_iterations == r.cg_iterations);
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

TEST_CASE("device PCG with a tolerance stops early and checks without per-iteration round trips", "[gpu]") {
  const bool persistent = GENERATE(true, false);
  const Model model = kernels_test_model(CellType::hexahedron, MaterialLaw::stvk);
  const State state = kernels_test_state(model, 5);
  DeviceElasticity dev(model);
  dev.set_state(state);
  StepOptions so;
  so.dt = 0.01;
  so.max_cg_iterations = 500;
  so.cg_tolerance = 1e-8;
  so.check_every = 8;
  so.persistent = persistent;
  so.external_forces = kernels_test_loads(model);
  DeviceBackwardEuler stepper(dev, so);
  const StepReport report = stepper.step();
  std::printf("[gpu] tolerance mode, persistent %d: %d iterations, relative residual %.2e\n", persistent ? 1 : 0,
              report.cg_iterations, report.cg_relative_residual);
  CHECK(report.persistent == persistent);
  CHECK(report.cg_iterations < 500);
  CHECK(report.cg_relative_residual <= 1e-8);
}

TEST_CASE("repeated device runs are bitwise identical", "[gpu]") {
  // Three runs, each from a new DeviceElasticity: gradient and energy, prepare, tangent product,
  // then 3 steps, persistent or launched; the values of the runs must be bitwise identical.
  const Shape shape = GENERATE(Shape::tetrahedra, Shape::hexahedra, Shape::single_samples);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const bool persistent = GENERATE(true, false);
  const Model model = test_model(shape, MaterialLaw::neo_hookean, 6, 5, 4);
  const State state = kernels_test_state(model, 8);
  const std::vector<double> d = random_vector(model.dof_count(), 6);
  DeviceOptions options;
  options.precision = precision;
  std::vector<std::vector<double>> results;
  for (int run = 0; run < 3; ++run) {
    DeviceElasticity dev(model, options);
    dev.set_state(state);
    std::vector<double> out(3 * model.dof_count() + 1);
    out.back() = dev.gradient(out.data());
    dev.prepare();
    dev.apply_tangent(d.data(), out.data() + model.dof_count());
    StepOptions so;
    so.persistent = persistent;
    so.external_forces = kernels_test_loads(model);
    DeviceBackwardEuler stepper(dev, so);
    for (int k = 0; k < 3; ++k) CHECK(stepper.step().persistent == persistent);
    stepper.last_increment(out.data() + 2 * model.dof_count());
    results.push_back(out);
  }
  REQUIRE(std::any_of(results[0].begin(), results[0].end() - 1, [](double v) { return v != 0; }));
  for (int run = 1; run < 3; ++run)
    CHECK(std::memcmp(results[run].data(), results[0].data(), results[0].size() * sizeof(double)) == 0);
}
