// The per-frame load body (mechanics/frame_loads.hpp), which the CUDA step evaluates, against the
// load potential of mechanics/external_loads.hpp: value, gradient and rotational Hessian blocks of
// every kind of load (gravity on the samples, frame point masses, point forces, material-point
// forces) at random large-rotation states and load factors.
//
// Tolerance: both sides sum the same products in different orders (per frame here, per pair or
// per load there), so they agree to a few ulps of the largest term: 1e-12 relative to the
// magnitude of the sums, with O(100) terms per frame at most.
#include "mechanics/frame_loads.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("frame-summed loads equal the load potential, gradient and rotational blocks", "[loads]") {
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

  std::vector<double> f, C, R;
  frame_load_moments(model, loads, f, C);
  rotation_matrices(state, R);
  const int n = model.frame_count();
  double value = 0;
  std::vector<double> gradient(6 * n, 0.0), blocks(9 * n, 0.0);
  for (int i = 0; i < n; ++i) {
    const Vec3 fi = load3(&f[3 * i]);
    const Mat3 Ci = load_mat3(&C[9 * i]), Ri = load_mat3(&R[9 * i]);
    value += frame_load_value(fi, Ci, load3(&state.positions[3 * i]), Ri, scale);
    Vec3 gx, gr;
    frame_load_gradient(fi, Ci, Ri, scale, gx, gr);
    store3(&gradient[6 * i], gx);
    store3(&gradient[6 * i + 3], gr);
    store_mat3(&blocks[9 * i], frame_load_rotational_block(Ci, Ri, scale));
  }

  const double v_ref = load_potential(model, loads, state);
  std::vector<double> g_ref(6 * n, 0.0), b_ref(9 * n, 0.0);
  add_load_gradient(model, loads, state, g_ref.data());
  add_load_rotational_blocks(model, loads, state, b_ref.data());

  // Magnitudes: the potential's largest term is about |f| |x| + |C|; compare against the sums of
  // absolute values to be independent of cancellation.
  double g_scale = 0, b_scale = 0;
  for (double x : g_ref) g_scale = std::max(g_scale, std::abs(x));
  for (double x : b_ref) b_scale = std::max(b_scale, std::abs(x));
  REQUIRE(g_scale > 0);
  REQUIRE(b_scale > 0);
  CHECK(std::abs(value - v_ref) <= 1e-12 * (std::abs(v_ref) + g_scale));
  for (int k = 0; k < 6 * n; ++k) CHECK(std::abs(gradient[k] - g_ref[k]) <= 1e-12 * g_scale);
  for (int k = 0; k < 9 * n; ++k) CHECK(std::abs(blocks[k] - b_ref[k]) <= 1e-12 * b_scale);
}
