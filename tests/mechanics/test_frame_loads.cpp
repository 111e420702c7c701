// The loads summed per frame (mechanics/frame_loads.hpp), which both backends evaluate: the value
// against the potential of mechanics/external_loads.hpp summed load by load (gravity on every
// sample through eq. (3), frame point masses, point forces, material-point forces), the gradient
// and the rotational Hessian blocks against finite differences of that value, at random
// large-rotation states and load factors.
//
// Tolerances: the value sums the same products in another order (per frame here, per load in the
// reference), so the two agree to a few ulps of the sum of the terms' magnitudes: 1e-12 of it,
// with O(100) terms per frame at most. The derivatives use the finite-difference harness's step
// sizes and tolerances (support/finite_difference.hpp: 1e-6 relative for gradients, 1e-5 for
// second derivatives).
#include "mechanics/frame_loads.hpp"
#include "mechanics/frame_sample.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;
using namespace fascia::test;

namespace {

// V of every load in turn and the sum of the terms' magnitudes.
struct LoadSum {
  double value = 0, magnitude = 0;
  void add(const Vec3& force, const Vec3& point) {
    value -= dot(force, point);
    magnitude += norm(force) * norm(point);
  }
};

LoadSum load_by_load(const Model& model, const ExternalLoads& loads, const State& state) {
  std::vector<double> R;
  rotation_matrices(state, R);
  const double s = loads.scale;
  const NeighbourTable& t = model.neighbours;
  const PairTableView view{t.offsets.data(), t.frames.data(), t.weights.data(), t.weight_gradients.data(),
                           t.rest_offsets.data()};
  LoadSum v;
  for (int k = 0; k < model.sample_count(); ++k) {
    const double m = model.materials[model.samples.materials[k]].density * model.samples.volumes[k];
    v.add((s * m) * loads.gravity, sample_position(view, k, state.positions.data(), R.data()));
  }
  for (size_t i = 0; i < model.frame_point_masses.size(); ++i)
    v.add((s * model.frame_point_masses[i]) * loads.gravity, load3(&state.positions[3 * i]));
  for (const PointForce& f : loads.point_forces) v.add(s * f.force, load3(&state.positions[3 * f.frame]));
  for (const MaterialPointForce& mp : loads.material_point_forces)
    for (size_t k = 0; k < mp.frames.size(); ++k) {
      const int i = mp.frames[k];
      const Vec3 p = load3(&state.positions[3 * i]) + load_mat3(&R[9 * i]) * load3(&mp.rest_offsets[3 * k]);
      v.add((s * mp.weights[k]) * mp.force, p);
    }
  return v;
}

}  // namespace

TEST_CASE("frame-summed loads: the load potential, its gradient and rotational blocks", "[loads]") {
  const unsigned seed = GENERATE(1u, 2u, 3u);
  const double scale = GENERATE(1.0, 0.37);
  Model model = small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 3, 2, 2);
  model.frame_point_masses.assign(model.frame_count(), 0.0);
  model.frame_point_masses[1] = 0.25;
  model.frame_point_masses[4] = 0.5;
  ExternalLoads loads;
  loads.gravity = Vec3{0.3, -1.2, -9.81};
  loads.scale = scale;
  loads.point_forces.push_back(PointForce{2, Vec3{1.5, -0.5, 0.25}});
  MaterialPointForce mp;
  mp.frames = {0, 3, 5};
  mp.weights = {0.2, 0.5, 0.3};
  mp.rest_offsets = {0.01, -0.02, 0.03, 0.0, 0.015, -0.01, -0.02, 0.0, 0.005};
  mp.force = Vec3{-2.0, 0.7, 1.1};
  loads.material_point_forces.push_back(mp);
  const State state = random_state(model, seed, 0.01, 0.8, 1.3);
  const FrameLoads frame_loads(model, loads);
  const int n = model.frame_count();

  const LoadSum reference = load_by_load(model, loads, state);
  REQUIRE(reference.magnitude > 0);
  CHECK(std::abs(frame_loads.value(state, scale) - reference.value) <= 1e-12 * reference.magnitude);

  std::vector<double> g(6 * n, 0.0), blocks(9 * n, 0.0);
  frame_loads.add_gradient(state, scale, g.data());
  frame_loads.add_rotational_blocks(state, scale, blocks.data());
  const Energy V = [&](const State& q) { return frame_loads.value(q, scale); };
  double g_scale = 0, b_scale = 0;
  for (double x : g) g_scale = std::max(g_scale, std::abs(x));
  for (double x : blocks) b_scale = std::max(b_scale, std::abs(x));
  REQUIRE(g_scale > 0);
  REQUIRE(b_scale > 0);
  const double length = 0.01;  // the box's cell size (m): the translations' scale in the directions
  for (unsigned k = 0; k < 3; ++k) {
    const std::vector<double> d = random_direction(model, 10 * seed + k, length);
    const std::vector<double> e = random_direction(model, 10 * seed + k + 100, length);
    double gd = 0, eHd = 0, gd_scale = 0, eHd_scale = 0;
    for (int i = 0; i < n; ++i) {
      for (int c = 0; c < 6; ++c) {
        gd += g[6 * i + c] * d[6 * i + c];
        gd_scale += std::abs(g[6 * i + c] * d[6 * i + c]);
      }
      // The Hessian of V is its rotational blocks: V is linear in the positions and sums frame by frame.
      const Vec3 Kd = load_mat3(&blocks[9 * i]) * load3(&d[6 * i + 3]);
      eHd += dot(load3(&e[6 * i + 3]), Kd);
      eHd_scale += norm(load3(&e[6 * i + 3])) * b_scale * norm(load3(&d[6 * i + 3]));
    }
    CHECK(std::abs(directional_derivative(model, V, state, d) - gd) <= 1e-6 * gd_scale);
    CHECK(std::abs(mixed_second_derivative(model, V, state, d, e) - eHd) <= 1e-5 * eHd_scale);
  }

  // The force scale of Newton's tolerance is the translational gradient's norm (a constant).
  double translational = 0;
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) translational += g[6 * i + c] * g[6 * i + c];
  CHECK(frame_loads.force_norm(scale) == Approx(std::sqrt(translational)).epsilon(1e-14));
}
