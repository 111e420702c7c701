// The CUDA elasticity against the CPU reference (fascia::Elasticity): energy, forces, tangent
// products and diagonal blocks, for the three laws (hgo with a fibre direction per sample: one
// family coupled, two uncoupled), both storage precisions, the grouped and the coalesced tangent
// pass, a frame pass that loops over its frames and a force pass whose reduction spans several
// chunks; and bitwise-identical repeated runs, steps included.
//
// Bounds. Double: 1e-12 relative (norm-wise); the device sums in other orders than the CPU, so
// results agree to a few ulps times the conditioning of the sums, far below 1e-12. Single: the
// model tables, frame kinematics and vectors are stored in float (unit roundoff 6e-8); strains of
// a few percent come from differences of O(1) terms, so the relative error of forces is bounded
// by about 1e-4 (measured values are printed).
#include "cuda_step.hpp"
#include "device_elasticity.hpp"
#include "integrate/simulation.hpp"
#include "kernels_fixtures.hpp"
#include "mechanics/elasticity.hpp"
#include "sample_layout.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <memory>
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

double bound(Precision p) { return p == Precision::double_precision ? 1e-12 : 1e-4; }

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
  const double tol = bound(c.precision);
  CHECK(e_energy < tol);
  // prepare() returns the energy of the tangent's storage: gradient()'s bits in double; in single
  // that of the float tables, within the precision's bound of the double energy gradient() gives.
  if (c.precision == Precision::double_precision)
    CHECK(dw2 == dw);
  else
    CHECK(std::abs(dw2 - dw) <= tol * std::abs(dw));
  CHECK(e_grad < tol);
  CHECK(e_tangent < tol);
  CHECK(e_blocks < tol);
}

TEST_CASE("a frame pass that loops over its frames and reductions that span several chunks equal the CPU reference",
          "[gpu]") {
  // 17 x 16 x 16 hexahedra, 34,816 samples: the force pass runs 272 blocks, so its energy sums per
  // chunk of 256 blocks (LaunchGrids::reduce_chunk), then over the chunks; 5,202 frames. The frame
  // pass loops over its 41 blocks of frames in at most 3 blocks (limit_row_blocks). Cells of 3.1
  // to 12 mm, positions perturbed by at most 0.5 mm (16 % of the thinnest cell, as the
  // 4 x 3 x 2-cell box's 4 mm of its 5 cm), no cell inverted.
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(CellType::hexahedron, MaterialLaw::neo_hookean, 17, 16, 16);
  const State state = kernels_test_state(model, 47, 5e-4);
  const int dofs = model.dof_count();
  Elasticity cpu(model, 1);
  std::vector<double> g(dofs), dg(dofs), Kd(dofs), dKd(dofs);
  const double w = cpu.gradient(state, g.data());
  cpu.prepare(state);
  const std::vector<double> d = random_vector(dofs, 12);
  cpu.apply_tangent(d.data(), Kd.data());

  DeviceOptions options;
  options.precision = precision;
  DeviceElasticity dev(model, options);
  REQUIRE(dev.group_samples());
  dev.limit_row_blocks(3);
  const LaunchGrids grids = dev.launch_grids();
  std::printf("[gpu] frame pass: %d blocks of work in %d blocks\n", grids.frame_work, grids.frame_grid);
  CHECK(grids.frame_grid < grids.frame_work);
  CHECK(model.sample_count() > 128 * grids.reduce_chunk);  // the force pass's 128-sample blocks
  dev.set_state(state);
  const double dw = dev.gradient(dg.data());
  dev.prepare(false);
  dev.apply_tangent(d.data(), dKd.data());
  const double e_energy = std::abs(dw - w) / std::abs(w), e_grad = relative_difference(dg, g),
               e_tangent = relative_difference(dKd, Kd);
  std::printf("[gpu] %d samples, %s: energy %.2e gradient %.2e tangent %.2e\n", model.sample_count(),
              to_string(precision), e_energy, e_grad, e_tangent);
  CHECK(e_energy < bound(precision));
  CHECK(e_grad < bound(precision));
  CHECK(e_tangent < bound(precision));
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

TEST_CASE("repeated device runs are bitwise identical", "[gpu]") {
  // Three runs, each from a new DeviceElasticity and a new device step: gradient and energy,
  // prepare, tangent product, then 3 backward-Euler steps of `fascia run --backend cuda`'s step
  // (kernels/cuda_step.hpp, block-Jacobi PCG to a tolerance); the values of the runs must be
  // bitwise identical.
  const Shape shape = GENERATE(Shape::tetrahedra, Shape::hexahedra, Shape::single_samples);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  // 6 x 5 x 4 cells of 1.25 cm and more: positions perturbed by at most 1 mm, no cell inverted.
  const Model model = test_model(shape, MaterialLaw::neo_hookean, 6, 5, 4);
  const State state = kernels_test_state(model, 8, 1e-3);
  const std::vector<double> d = random_vector(model.dof_count(), 6);
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.newton.linear.preconditioner = Preconditioner::block_jacobi;
  settings.newton.linear.tolerance = 1e-6;
  // Single precision stores forces to about 1e-6 relative: Newton's tolerance above that.
  settings.newton.tolerance = precision == Precision::double_precision ? 1e-8 : 1e-4;
  DeviceOptions options;
  options.precision = precision;
  std::vector<std::vector<double>> results;
  for (int run = 0; run < 3; ++run) {
    DeviceElasticity dev(model, options);
    dev.set_state(state);
    std::vector<double> out(2 * model.dof_count() + 1);
    out.back() = dev.gradient(out.data());
    REQUIRE(std::isfinite(out.back()));
    dev.prepare();
    dev.apply_tangent(d.data(), out.data() + model.dof_count());
    std::string why;
    const std::unique_ptr<StepBackend> step = cuda_step_factory(options)(model, loads, settings, why);
    REQUIRE(step);
    State q = state;
    for (int k = 0; k < 3; ++k) {
      const State start = q;
      const NewtonResult r = step->backward_euler(start, q, 0.01, 0.0, settings.newton, 0.0);
      CHECK(r.converged());
      CHECK(r.iterations > 0);
    }
    out.insert(out.end(), q.positions.begin(), q.positions.end());
    out.insert(out.end(), q.orientations.begin(), q.orientations.end());
    out.insert(out.end(), q.velocities.begin(), q.velocities.end());
    results.push_back(out);
  }
  REQUIRE(std::any_of(results[0].begin(), results[0].end() - 1, [](double v) { return v != 0; }));
  for (int run = 1; run < 3; ++run)
    CHECK(std::memcmp(results[run].data(), results[0].data(), results[0].size() * sizeof(double)) == 0);
}
