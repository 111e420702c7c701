// The CUDA backend against the CPU reference (fascia::Elasticity and the host PCG of
// reference_step.hpp): energy, forces, tangent products, diagonal blocks and a full Newton step,
// for both designs (paper, fused), both laws and both storage precisions; and bitwise-identical
// repeated runs.
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

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

namespace {

struct Case {
  Precision precision;
  Design design;
  CellType type;
  MaterialLaw law;
};

double bound(Precision p, bool step) {
  if (p == Precision::double_precision) return 1e-12;
  return step ? 1e-3 : 1e-4;
}

const char* name(CellType t) { return t == CellType::tetrahedron ? "tet" : "hex"; }

std::vector<double> random_vector(int dofs, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> d(dofs);
  for (int j = 0; j < dofs; ++j) d[j] = (j % 6 < 3 ? 0.01 : 1.0) * u(rng);
  return d;
}

}  // namespace

TEST_CASE("device forces, tangent products and diagonal blocks equal the CPU reference", "[gpu]") {
  const Case c = GENERATE(Case{Precision::double_precision, Design::fused, CellType::tetrahedron, MaterialLaw::stvk},
                          Case{Precision::double_precision, Design::fused, CellType::hexahedron, MaterialLaw::stvk},
                          Case{Precision::double_precision, Design::fused, CellType::hexahedron, MaterialLaw::neo_hookean},
                          Case{Precision::double_precision, Design::paper, CellType::tetrahedron, MaterialLaw::stvk},
                          Case{Precision::double_precision, Design::paper, CellType::hexahedron, MaterialLaw::neo_hookean},
                          Case{Precision::single_precision, Design::fused, CellType::tetrahedron, MaterialLaw::stvk},
                          Case{Precision::single_precision, Design::fused, CellType::hexahedron, MaterialLaw::neo_hookean},
                          Case{Precision::single_precision, Design::paper, CellType::hexahedron, MaterialLaw::stvk});
  // Fused design: every sample pass of the tangent product.
  const SamplePass pass = GENERATE(SamplePass::records, SamplePass::lanes, SamplePass::staged, SamplePass::coalesced);
  const Model model = kernels_test_model(c.type, c.law);
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
  options.design = c.design;
  options.block_samples = 32;  // several blocks even on the small test model
  options.sample_pass = pass;
  DeviceElasticity dev(model, options);
  REQUIRE(dev.design() == c.design);
  if (c.design == Design::fused) REQUIRE(dev.sample_pass() == pass);
  dev.set_state(state);
  std::vector<double> dg(dofs), dKd(dofs), dblocks(36 * n);
  const double dw = dev.gradient(dg.data());
  const double dw2 = dev.prepare();
  dev.tangent_diagonal_blocks(dblocks.data());
  dev.apply_tangent(d.data(), dKd.data());

  const double e_energy = std::abs(dw - w) / std::abs(w), e_grad = relative_difference(dg, g),
               e_tangent = relative_difference(dKd, Kd), e_blocks = relative_difference(dblocks, blocks);
  std::printf("[gpu] %s %s/%s %s %s: energy %.2e gradient %.2e tangent %.2e blocks %.2e\n", to_string(c.precision),
              to_string(c.design), dev.design() == Design::fused ? to_string(dev.sample_pass()) : "", name(c.type), to_string(c.law), e_energy, e_grad,
              e_tangent, e_blocks);
  const double tol = bound(c.precision, false);
  CHECK(e_energy < tol);
  CHECK(dw2 == dw);
  CHECK(e_grad < tol);
  CHECK(e_tangent < tol);
  CHECK(e_blocks < tol);
}

namespace {

// The device tangent product's relative difference from the CPU engine's on `model` in a random
// state (kernels_test_state(state_seed)) for a random direction (random_vector(direction_seed));
// `inspect` sees the device object before the product.
template <class Inspect>
double tangent_difference(const Model& model, unsigned state_seed, unsigned direction_seed,
                          const DeviceOptions& options, Inspect inspect) {
  const State state = kernels_test_state(model, state_seed);
  const int dofs = model.dof_count();
  Elasticity cpu(model, 1);
  cpu.prepare(state);
  const std::vector<double> d = random_vector(dofs, direction_seed);
  std::vector<double> Kd(dofs), dKd(dofs);
  cpu.apply_tangent(d.data(), Kd.data());
  DeviceElasticity dev(model, options);
  inspect(static_cast<const DeviceElasticity&>(dev));
  dev.set_state(state);
  dev.prepare();
  dev.apply_tangent(d.data(), dKd.data());
  return relative_difference(dKd, Kd);
}

// One launched-PCG step (60 CG iterations, kernels_test_loads, h = 0.01) on `model` from
// kernels_test_state(state_seed) against the CPU reference step: checks that it ran launched with
// the reference's CG iteration count (into `iterations`) and returns the increments' relative
// difference. `inspect` sees the device object before the step.
template <class Inspect>
double launched_step_difference(const Model& model, unsigned state_seed, const DeviceOptions& options,
                                Inspect inspect, int& iterations, double displacement = 0.004) {
  const State state = kernels_test_state(model, state_seed, displacement);
  const double h = 0.01;
  const std::vector<double> loads = kernels_test_loads(model);
  const ReferenceStep ref = reference_step(model, state, h, 60, loads);
  DeviceElasticity dev(model, options);
  inspect(static_cast<const DeviceElasticity&>(dev));
  dev.set_state(state);
  StepOptions so;
  so.dt = h;
  so.max_cg_iterations = 60;
  so.persistent = false;
  so.external_forces = loads;
  DeviceBackwardEuler stepper(dev, so);
  const StepReport report = stepper.step();
  CHECK_FALSE(report.persistent);
  CHECK(report.cg_iterations == ref.iterations);
  iterations = report.cg_iterations;
  std::vector<double> delta(model.dof_count());
  stepper.last_increment(delta.data());
  return relative_difference(delta, ref.delta);
}

}  // namespace

TEST_CASE("record and coalesced passes equal the CPU reference with every lane count", "[gpu]") {
  // 8 neighbours per sample. Records pass: each lane keeps `keep` pairs in registers and reads the
  // others again for the outputs (1 lane, keep 1: 7 pairs read again); with 8 lanes every pair is
  // kept. The coalesced pass sizes its register-held entries itself (keep does not apply).
  const SamplePass pass = GENERATE(SamplePass::records, SamplePass::coalesced);
  const int lanes = GENERATE(1, 2, 4, 8);
  const int keep = GENERATE(1, 2);
  const int slot_lanes = GENERATE(1, 2, 8, 32);  // coalesced pass: lanes per slot sum
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(CellType::hexahedron, MaterialLaw::neo_hookean);
  DeviceOptions options;
  options.precision = precision;
  options.block_samples = 32;
  options.sample_pass = pass;
  options.group_samples = false;  // the coalesced kernels themselves (the grouped pass: below)
  options.lanes = lanes;
  options.record_keep = keep;
  options.slot_lanes = slot_lanes;
  const double e = tangent_difference(model, 13, 5, options, [&](const DeviceElasticity& dev) {
    REQUIRE(dev.sample_pass() == pass);
    REQUIRE(dev.lanes() == lanes);
  });
  std::printf("[gpu] %s %s lanes %d keep %d slot lanes %d: tangent %.2e\n", to_string(pass), to_string(precision), lanes,
              keep, slot_lanes, e);
  CHECK(e < bound(precision, false));
}

TEST_CASE("dense and mapped coalesced tangent kernels equal the CPU reference", "[gpu]") {
  // 128-sample blocks with one lane (128 threads: the dense kernels' block size); every count of
  // held entries; w and g per pair or from the shape classes (kernels/shape_classes.hpp).
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const bool dense = GENERATE(false, true);
  const bool mapped = GENERATE(false, true);
  const int keep = GENERATE(2, 4, 8);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, MaterialLaw::neo_hookean);
  DeviceOptions options;
  options.precision = precision;
  options.lanes = 1;
  options.coalesced_keep = keep;
  options.dense_tangent = dense;
  options.shape_classes = mapped;
  options.group_samples = false;
  const double e = tangent_difference(model, 17, 7, options, [&](const DeviceElasticity& dev) {
    REQUIRE(dev.sample_pass() == SamplePass::coalesced);
    CHECK(dev.dense_tangent() == dense);
    CHECK(dev.shape_classes() == mapped);
  });
  std::printf("[gpu] coalesced %s %s keep %d dense %d mapped %d: tangent %.2e\n", name(type), to_string(precision),
              keep, dense ? 1 : 0, mapped ? 1 : 0, e);
  CHECK(e < bound(precision, false));
}

TEST_CASE("device backward-Euler Newton step equals the CPU reference", "[gpu]") {
  const Case c = GENERATE(Case{Precision::double_precision, Design::fused, CellType::tetrahedron, MaterialLaw::stvk},
                          Case{Precision::double_precision, Design::fused, CellType::hexahedron, MaterialLaw::neo_hookean},
                          Case{Precision::double_precision, Design::paper, CellType::hexahedron, MaterialLaw::stvk},
                          Case{Precision::single_precision, Design::fused, CellType::tetrahedron, MaterialLaw::stvk});
  const bool graphs = GENERATE(true, false);
  const bool persistent = GENERATE(true, false);
  const SamplePass pass = GENERATE(SamplePass::records, SamplePass::lanes, SamplePass::staged, SamplePass::coalesced);
  const Model model = kernels_test_model(c.type, c.law);
  const State state = kernels_test_state(model, 33);
  const double h = 0.01;
  const std::vector<double> loads = kernels_test_loads(model);
  const ReferenceStep ref = reference_step(model, state, h, 60, loads);

  DeviceOptions options;
  options.precision = c.precision;
  options.design = c.design;
  options.block_samples = 32;
  options.sample_pass = pass;
  DeviceElasticity dev(model, options);
  if (c.design == Design::fused) REQUIRE(dev.sample_pass() == pass);
  dev.set_state(state);
  StepOptions so;
  so.dt = h;
  so.max_cg_iterations = 60;
  so.use_graphs = graphs;
  so.persistent = persistent;
  so.external_forces = loads;
  DeviceBackwardEuler stepper(dev, so);
  const StepReport report = stepper.step();
  CHECK(report.persistent == (persistent && dev.design() == Design::fused));
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
  std::printf(
      "[gpu] step %s %s/%s %s %s graphs=%d persistent=%d: cg %d (cpu %d) delta %.2e positions %.2e velocities %.2e\n",
      to_string(c.precision), to_string(c.design), dev.design() == Design::fused ? to_string(dev.sample_pass()) : "", name(c.type), to_string(c.law),
      graphs ? 1 : 0,
      report.persistent ? 1 : 0, report.cg_iterations, ref.iterations, e_delta, e_pos, e_vel);
  CHECK(report.cg_iterations == ref.iterations);
  const double tol = bound(c.precision, true);
  CHECK(e_delta < tol);
  CHECK(e_pos < tol);
  CHECK(e_vel < tol);
}

TEST_CASE("launched PCG with the dense and mapped tangent kernels equals the CPU reference", "[gpu]") {
  // The launched tangent product is the only user of these kernels in a step (the persistent
  // kernels read the per-pair table), so the step runs without the persistent PCG.
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, MaterialLaw::stvk);
  DeviceOptions options;
  options.precision = precision;
  options.lanes = 1;
  options.dense_tangent = true;
  options.shape_classes = true;
  options.group_samples = false;
  int iterations = 0;
  const double e = launched_step_difference(model, 37, options, [](const DeviceElasticity& dev) {
    REQUIRE(dev.dense_tangent());
    REQUIRE(dev.shape_classes());
  }, iterations);
  std::printf("[gpu] launched dense mapped %s %s: cg %d delta %.2e\n", to_string(precision), name(type), iterations,
              e);
  CHECK(e < bound(precision, true));
}

TEST_CASE("grouped tangent pass equals the CPU reference", "[gpu]") {
  // Hexahedra: groups of 8 samples on 8 frames; tetrahedra: 4 samples on 4 frames (half of each
  // group's threads idle). Every slot-sum width; w and g per pair or from the groups' classes.
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const int slot_lanes = GENERATE(1, 2, 32);
  const bool classes = GENERATE(false, true);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, law, 5, 4, 3);
  DeviceOptions options;
  options.precision = precision;
  options.group_samples = true;
  options.group_classes = classes;
  options.slot_lanes = slot_lanes;
  const double e = tangent_difference(model, 19, 3, options, [&](const DeviceElasticity& dev) {
    INFO(dev.group_samples_refusal() << dev.group_classes_refusal());
    REQUIRE(dev.group_samples());
    REQUIRE(dev.group_classes() == classes);
  });
  std::printf("[gpu] grouped %s %s %s slot lanes %d classes %d: tangent %.2e\n", name(type), to_string(law),
              to_string(precision), slot_lanes, classes ? 1 : 0, e);
  CHECK(e < bound(precision, false));
}

TEST_CASE("launched PCG with the grouped pass equals the CPU reference", "[gpu]") {
  // The grouped kernel forms the direction z + beta p_old itself, or reads p from the direction
  // pass; the persistent kernels keep the coalesced pass, so the step runs launched.
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const bool direction_pass = GENERATE(false, true);
  const bool classes = GENERATE(false, true);
  const Model model = kernels_test_model(type, MaterialLaw::stvk);
  DeviceOptions options;
  options.precision = precision;
  options.group_samples = true;
  options.direction_pass = direction_pass;
  options.group_classes = classes;
  int iterations = 0;
  const double e = launched_step_difference(model, 43, options, [&](const DeviceElasticity& dev) {
    REQUIRE(dev.group_samples());
    REQUIRE(dev.group_classes() == classes);
  }, iterations);
  std::printf("[gpu] launched grouped %s %s direction pass %d classes %d: cg %d delta %.2e\n", to_string(precision),
              name(type), direction_pass ? 1 : 0, classes ? 1 : 0, iterations, e);
  CHECK(e < bound(precision, true));
}

TEST_CASE("launched row passes that loop and reduce over many chunks equal the CPU reference", "[gpu]") {
  // Every last-block reduction sums per chunk of 256 blocks (LaunchGrids::reduce_chunk), then over
  // the chunks, and the row passes loop over their work in at most the blocks that fit on the
  // device at once (here fewer: DeviceOptions::row_blocks). 8 x 7 x 6 hexahedra, 504 frames. One
  // thread per frame row, one frame per chunk (row_frames 1): 504 chunks in 300 blocks, more than
  // 256. With the frame pass's one thread per frame: 4 blocks of frames and 504 chunks in 3
  // blocks. Grouped and coalesced passes, both precisions. Cells of 8.3 to 25 mm, positions
  // perturbed by at most 1.3 mm: the strains of the 4 x 3 x 2-cell box's tests (16 % of the
  // thinnest cell), no cell inverted.
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const bool grouped = GENERATE(false, true);
  const bool frame_threads = GENERATE(false, true);
  const Model model = kernels_test_model(CellType::hexahedron, MaterialLaw::neo_hookean, 8, 7, 6);
  DeviceOptions options;
  options.precision = precision;
  options.group_samples = grouped;
  options.frame_threads = frame_threads;
  options.row_frames = 1;
  options.row_blocks = frame_threads ? 3 : 300;
  int iterations = 0;
  const double e = launched_step_difference(model, 47, options, [&](const DeviceElasticity& dev) {
    REQUIRE(dev.group_samples() == grouped);
    const LaunchGrids grids = dev.launch_grids();
    std::printf("[gpu] row passes: %d and %d blocks of work in %d and %d blocks\n", grids.frame_work,
                grids.update_work, grids.frame_rows_grid, grids.update_rows_grid);
    // Each pass loops more than once in some blocks; one thread per row, the reductions span
    // two chunks.
    CHECK(grids.frame_rows_grid < grids.frame_work);
    CHECK(grids.update_rows_grid < grids.update_work);
    if (!frame_threads) {
      CHECK(grids.frame_rows_grid > grids.reduce_chunk);
      CHECK(grids.update_rows_grid > grids.reduce_chunk);
    }
  }, iterations, 1.3e-3);
  std::printf("[gpu] launched, %d samples, %s, %s grouped %d: cg %d delta %.2e\n", model.sample_count(),
              frame_threads ? "frame threads" : "one frame per chunk", to_string(precision), grouped ? 1 : 0,
              iterations, e);
  CHECK(e < bound(precision, true));
}

TEST_CASE("the grouped pass is refused where samples share no frames", "[gpu]") {
  // One sample per tetrahedron: every group holds one sample, below the 2 the pass needs; the
  // coalesced pass runs instead, and says why.
  const Model model = kernels_test_model(CellType::tetrahedron, MaterialLaw::stvk);
  // Each frame set's first sample only (reorder_samples with a subset of the samples).
  std::vector<int> order;
  {
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
  }
  REQUIRE(static_cast<int>(order.size()) < model.sample_count());
  DeviceOptions options;
  options.group_samples = true;
  DeviceElasticity dev(reorder_samples(model, order), options);
  CHECK_FALSE(dev.group_samples());
  CHECK(dev.group_samples_refusal().find("average 1.00 samples") != std::string::npos);
  CHECK(dev.sample_pass() == SamplePass::coalesced);
}

namespace {

// The device tangent product K d and the increment of one launched-PCG step (the tangent kernel
// forms the direction z + beta p_old itself there) with the given options.
struct LaunchedRun {
  std::vector<double> Kd, delta;
};
double length(const std::vector<double>& a) { return std::sqrt(std::inner_product(a.begin(), a.end(), a.begin(), 0.0)); }
LaunchedRun launched_run(const Model& model, const DeviceOptions& options) {
  const State state = kernels_test_state(model, 41);
  LaunchedRun out{std::vector<double>(model.dof_count()), std::vector<double>(model.dof_count())};
  DeviceElasticity dev(model, options);
  REQUIRE(dev.slot_frames() == options.slot_frames);
  REQUIRE(dev.direction_pass() == options.direction_pass);
  REQUIRE(dev.hold_pairs() == options.hold_pairs);
  REQUIRE(dev.prefetch_frames() == options.prefetch_frames);
  dev.set_state(state);
  dev.prepare();
  const std::vector<double> d = random_vector(model.dof_count(), 11);
  dev.apply_tangent(d.data(), out.Kd.data());
  StepOptions so;
  so.dt = 0.01;
  so.max_cg_iterations = 40;
  so.persistent = false;
  so.external_forces = kernels_test_loads(model);
  DeviceBackwardEuler stepper(dev, so);
  const StepReport report = stepper.step();
  REQUIRE_FALSE(report.persistent);
  stepper.last_increment(out.delta.data());
  return out;
}

// A launched run with one option changed against the run without it: the same bits (memcmp of
// K d and of the PCG increment), both non-zero so that the comparison can fail.
void check_same_bits(const LaunchedRun& without, const LaunchedRun& with) {
  REQUIRE(length(without.Kd) > 0);
  REQUIRE(length(without.delta) > 0);
  CHECK(std::memcmp(with.Kd.data(), without.Kd.data(), sizeof(double) * without.Kd.size()) == 0);
  CHECK(std::memcmp(with.delta.data(), without.delta.data(), sizeof(double) * without.delta.size()) == 0);
}

// The launched dense coalesced tangent kernel with `keep` held entries, one lane per sample.
DeviceOptions dense_options(Precision precision, int keep) {
  DeviceOptions options;
  options.precision = precision;
  options.lanes = 1;
  options.coalesced_keep = keep;
  options.dense_tangent = true;
  options.group_samples = false;
  return options;
}

}  // namespace

TEST_CASE("the frame pass with one thread per frame gives the values of one thread per row", "[gpu]") {
  // The same arithmetic per row (slot sums in slot order): the tangent product gives the same
  // bits; in a PCG step p . A p adds in another order, so the increment agrees within the bounds
  // above (and with the CPU reference elsewhere).
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const bool grouped = GENERATE(false, true);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, MaterialLaw::neo_hookean, 6, 5, 4);
  DeviceOptions options;
  options.precision = precision;
  options.group_samples = grouped;
  options.frame_threads = false;
  const LaunchedRun rows = launched_run(model, options);
  options.frame_threads = true;
  const LaunchedRun frames = launched_run(model, options);
  REQUIRE(length(rows.Kd) > 0);
  CHECK(std::memcmp(frames.Kd.data(), rows.Kd.data(), sizeof(double) * rows.Kd.size()) == 0);
  const double e = relative_difference(frames.delta, rows.delta);
  std::printf("[gpu] frame threads %s %s grouped %d: |Kd| %.3e, delta against rows %.2e\n", name(type),
              to_string(precision), grouped ? 1 : 0, length(rows.Kd), e);
  CHECK(e < bound(precision, true));
}

TEST_CASE("slot-frames tangent kernel gives the bits of the gathering kernel", "[gpu]") {
  // The staged frame records hold the gathered values and the direction formed by the same
  // function, and every sum keeps its order, so the tangent product and a launched PCG step agree
  // bit for bit; the CPU comparison of the gathering kernel (above) then covers both.
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const int keep = GENERATE(2, 4, 8);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, MaterialLaw::neo_hookean, 6, 5, 4);
  DeviceOptions options = dense_options(precision, keep);
  const LaunchedRun gathered = launched_run(model, options);
  options.slot_frames = true;
  const LaunchedRun staged = launched_run(model, options);
  std::printf("[gpu] slot frames %s %s keep %d: |Kd| %.3e, |delta| %.3e\n", name(type), to_string(precision), keep,
              length(gathered.Kd), length(gathered.delta));
  check_same_bits(gathered, staged);
}

TEST_CASE("held-pairs and prefetched-frames tangent kernels give the bits of the gathering kernel", "[gpu]") {
  // Held pairs: the output half uses the pairs the dF half formed instead of forming them again
  // from the same gathered values. Prefetched frames: the next pairs' frames are read earlier.
  // Either way the values and every sum's order are the same: the same bits, in the tangent
  // product and a launched PCG step. Hexahedra have 8 pairs per sample, so with 2 and 4 held
  // entries the prefetched and the later pairs are both exercised.
  const bool hold = GENERATE(true, false);  // else prefetched frames
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const int keep = GENERATE(2, 4);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, MaterialLaw::neo_hookean, 6, 5, 4);
  DeviceOptions options = dense_options(precision, keep);
  const LaunchedRun gathered = launched_run(model, options);
  options.hold_pairs = hold;
  options.prefetch_frames = !hold;
  const LaunchedRun variant = launched_run(model, options);
  std::printf("[gpu] %s %s %s keep %d: |Kd| %.3e, |delta| %.3e\n", hold ? "held pairs" : "prefetched frames",
              name(type), to_string(precision), keep, length(gathered.Kd), length(gathered.delta));
  check_same_bits(gathered, variant);
}

TEST_CASE("direction pass gives the bits of the direction formed in the tangent pass", "[gpu]") {
  // k_pcg_direction forms p = z + beta p with the rounding the tangent and frame passes use
  // (next_direction), and every sum keeps its order, so a launched PCG step agrees bit for bit,
  // with frames gathered per pair and staged per block; the CPU comparison of the launched PCG
  // (above) then covers both.
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const bool slot_frames = GENERATE(false, true);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, MaterialLaw::stvk, 6, 5, 4);
  DeviceOptions options;
  options.precision = precision;
  options.lanes = 1;
  options.slot_frames = slot_frames;
  options.group_samples = false;
  const LaunchedRun formed = launched_run(model, options);
  options.direction_pass = true;
  const LaunchedRun passed = launched_run(model, options);
  std::printf("[gpu] direction pass %s %s slot frames %d: |delta| %.3e\n", name(type), to_string(precision),
              slot_frames ? 1 : 0, length(formed.delta));
  check_same_bits(formed, passed);
}

TEST_CASE("resident and two-barrier persistent PCG equal the CPU reference", "[gpu]") {
  // The coalesced pass's persistent PCG with the loop invariants in registers (k_pcg_resident) and
  // without (k_pcg_two_barrier): the same arithmetic, so the same increment bit for bit, and the
  // CPU reference's within the bounds above. Tetrahedra (4 pairs) and hexahedra (8 pairs), both
  // laws (the double kernel forms the material cache again each iteration). The kernel with its
  // blocks' frames staged in shared memory (DeviceOptions::resident_frames) too: the same bits again.
  // The two-barrier kernel with one lane per slot sum, as the resident kernel sums its slots.
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const Model model = kernels_test_model(type, law);
  const State state = kernels_test_state(model, 35);
  const double h = 0.01;
  const std::vector<double> loads = kernels_test_loads(model);
  const ReferenceStep ref = reference_step(model, state, h, 60, loads);
  std::vector<std::vector<double>> deltas;
  for (int variant : {0, 1, 2}) {  // resident with staged levers, resident, two-barrier
    const bool resident = variant < 2;
    DeviceOptions options;
    options.precision = precision;
    options.resident = resident;  // 128-sample blocks (the resident kernel's size)
    options.resident_double = resident;
    options.resident_frames = variant == 0;
    options.slot_lanes = 1;  // the resident kernel sums each slot with one thread
    DeviceElasticity dev(model, options);
    REQUIRE(dev.sample_pass() == SamplePass::coalesced);
    dev.set_state(state);
    StepOptions so;
    so.dt = h;
    so.max_cg_iterations = 60;
    so.external_forces = loads;
    DeviceBackwardEuler stepper(dev, so);
    const StepReport report = stepper.step();
    CHECK(report.persistent);
    // The resident kernel runs in single precision, and in double for 4 pairs per sample (with 8
    // the double kernel needs local memory; DeviceOptions::resident).
    CHECK(report.resident ==
          (resident && (precision == Precision::single_precision || type == CellType::tetrahedron)));
    CHECK(dev.resident_frames() ==
          (variant == 0 && precision == Precision::double_precision && type == CellType::tetrahedron));
    CHECK(report.cg_iterations == ref.iterations);
    std::vector<double> delta(model.dof_count());
    stepper.last_increment(delta.data());
    const double e = relative_difference(delta, ref.delta);
    std::printf("[gpu] %s %s %s %s: kernel %s%s, cg %d delta %.2e\n",
                variant == 0 ? "resident, staged frames" : resident ? "resident" : "two-barrier", to_string(precision),
                name(type), to_string(law), report.resident ? "resident" : "two-barrier",
                dev.resident_frames() ? " (staged frames)" : "", report.cg_iterations, e);
    CHECK(e < bound(precision, true));
    deltas.push_back(delta);
  }
  CHECK(std::memcmp(deltas[0].data(), deltas[1].data(), deltas[0].size() * sizeof(double)) == 0);
  CHECK(std::memcmp(deltas[0].data(), deltas[2].data(), deltas[0].size() * sizeof(double)) == 0);
}

// The device step against the CPU engine itself: StepPotential (backward Euler with Rayleigh
// damping, gravity on the samples) minimised by one Newton iteration with 60 fixed CG or PCG
// iterations, as `fascia bench cpu` times it, then v = Delta / h.
TEST_CASE("device step equals the CPU engine's one-iteration Newton step", "[gpu]") {
  const Design design = GENERATE(Design::fused, Design::paper);
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

  DeviceOptions options;
  options.design = design;
  options.block_samples = 32;
  DeviceImplicitStep device(model, options);
  State gpu = start;
  const StepReport report = device.step(gpu, loads, h, alpha, beta, newton.linear);

  const double e_pos = relative_difference(gpu.positions, cpu.positions);
  const double e_rot = relative_difference(gpu.orientations, cpu.orientations);
  const double e_vel = relative_difference(gpu.velocities, cpu.velocities);
  std::printf("[gpu] engine step %s %s alpha=%g: cg %d (cpu %d) positions %.2e orientations %.2e velocities %.2e\n",
              to_string(design), to_string(method), alpha, report.cg_iterations, r.cg_iterations, e_pos, e_rot, e_vel);
  CHECK(report.cg_iterations == r.cg_iterations);
  // PCG: the same operator, right-hand side and preconditioner give the same step to round-off.
  // Plain CG: 60 iterations far from convergence on H, whose translational (m/h^2) and rotational
  // (I/h^2) scales differ by orders of magnitude, amplify the round-off of different summation
  // orders (measured on an H200: 1e-6 to 2.5e-4 relative, for both designs); the PCG cases above
  // check the definition, this bound checks that CG solves the same system.
  const double tol = method == LinearMethod::pcg ? 1e-12 : 1e-3;
  CHECK(e_pos < tol);
  CHECK(e_rot < tol);
  CHECK(e_vel < tol);
}

TEST_CASE("device PCG with a tolerance stops early and checks without per-iteration round trips", "[gpu]") {
  const Model model = kernels_test_model(CellType::hexahedron, MaterialLaw::stvk);
  const State state = kernels_test_state(model, 5);
  DeviceElasticity dev(model);
  dev.set_state(state);
  StepOptions so;
  so.dt = 0.01;
  so.max_cg_iterations = 500;
  so.cg_tolerance = 1e-8;
  so.check_every = 8;
  so.external_forces = kernels_test_loads(model);
  DeviceBackwardEuler stepper(dev, so);
  const StepReport report = stepper.step();
  std::printf("[gpu] tolerance mode: %d iterations, relative residual %.2e\n", report.cg_iterations,
              report.cg_relative_residual);
  CHECK(report.cg_iterations < 500);
  CHECK(report.cg_relative_residual <= 1e-8);
}

namespace {

// Three device runs of `model` in the state kernels_test_state(state_seed), each from a new
// DeviceElasticity: gradient and energy, prepare, tangent product of random_vector(direction_seed),
// then 3 steps with `persistent`; the values of the runs must be bitwise identical. `inspect` sees
// each device object after construction.
template <class Inspect>
void check_bitwise_repeats(const Model& model, unsigned state_seed, unsigned direction_seed,
                           const DeviceOptions& options, bool persistent, Inspect inspect) {
  const State state = kernels_test_state(model, state_seed);
  const std::vector<double> d = random_vector(model.dof_count(), direction_seed);
  std::vector<std::vector<double>> results;
  for (int run = 0; run < 3; ++run) {
    DeviceElasticity dev(model, options);
    inspect(static_cast<const DeviceElasticity&>(dev));
    dev.set_state(state);
    std::vector<double> out(3 * model.dof_count() + 1);
    out.back() = dev.gradient(out.data());
    dev.prepare();
    dev.apply_tangent(d.data(), out.data() + model.dof_count());
    StepOptions so;
    so.persistent = persistent;
    so.external_forces = kernels_test_loads(model);
    DeviceBackwardEuler stepper(dev, so);
    for (int k = 0; k < 3; ++k) stepper.step();
    stepper.last_increment(out.data() + 2 * model.dof_count());
    results.push_back(out);
  }
  for (int run = 1; run < 3; ++run)
    CHECK(std::memcmp(results[run].data(), results[0].data(), results[0].size() * sizeof(double)) == 0);
}

}  // namespace

TEST_CASE("repeated device runs with the dense and mapped tangent kernels and the double resident PCG are bitwise identical", "[gpu]") {
  // Dense and mapped tangent kernels (in the tangent product and a launched PCG) and the resident
  // PCG in double (tetrahedra: 4 pairs per sample).
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const bool persistent = GENERATE(true, false);
  DeviceOptions options;
  options.precision = precision;
  options.lanes = 1;
  options.dense_tangent = true;
  options.shape_classes = true;
  options.group_samples = false;
  options.resident_double = true;
  check_bitwise_repeats(kernels_test_model(type, MaterialLaw::neo_hookean, 6, 5, 4), 9, 10, options, persistent,
                        [](const DeviceElasticity& dev) {
                          REQUIRE(dev.dense_tangent());
                          REQUIRE(dev.shape_classes());
                        });
}

TEST_CASE("repeated device runs with the grouped pass are bitwise identical", "[gpu]") {
  // The grouped pass in the tangent product and a launched PCG (its sums in fixed orders: the
  // group's reduce-scatter, the slot sums, the frame rows).
  const CellType type = GENERATE(CellType::tetrahedron, CellType::hexahedron);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const bool classes = GENERATE(false, true);
  DeviceOptions options;
  options.precision = precision;
  options.group_samples = true;
  options.group_classes = classes;
  check_bitwise_repeats(kernels_test_model(type, MaterialLaw::neo_hookean, 6, 5, 4), 9, 10, options, false,
                        [&](const DeviceElasticity& dev) {
                          REQUIRE(dev.group_samples());
                          REQUIRE(dev.group_classes() == classes);
                        });
}

TEST_CASE("repeated device runs are bitwise identical", "[gpu]") {
  const Design design = GENERATE(Design::fused, Design::paper);
  const Precision precision = GENERATE(Precision::double_precision, Precision::single_precision);
  const SamplePass pass = GENERATE(SamplePass::records, SamplePass::lanes, SamplePass::staged, SamplePass::coalesced);
  DeviceOptions options;
  options.precision = precision;
  options.design = design;
  options.sample_pass = pass;
  check_bitwise_repeats(kernels_test_model(CellType::hexahedron, MaterialLaw::neo_hookean, 6, 5, 4), 8, 6, options,
                        StepOptions{}.persistent, [](const DeviceElasticity&) {});
}
