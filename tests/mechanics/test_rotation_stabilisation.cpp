// The rotation stabilisation of frame hexahedra (mechanics/rotation_stabilisation.hpp):
// finite-difference checks of gradient and tangent, rigid-motion invariance, and that it gives
// the hexahedra's zero-energy modes the stiffness derived in docs/solvers.md.
#include "core/rotation.hpp"
#include "mechanics/elasticity.hpp"
#include "mechanics/rotation_stabilisation.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

using namespace fascia;
using namespace fascia::test;

namespace {

// The box of fixtures.hpp is 0.2 x 0.1 x 0.05 m; its cells are 5 to 10 cm.
constexpr double kLength = 0.05;

}  // namespace

TEST_CASE("rotation stabilisation: gradient and tangent are the derivatives of the re-parametrised energy",
          "[mechanics][rotation_stabilisation][fd]") {
  // Deformed states with displacements of 5 mm, frame rotations up to `rotation` rad and a global
  // rotation of 2.5 rad, so that the relative rotations R_i^T R_j are far from I.
  const double rotation = GENERATE(0.05, 0.8);
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk, 2, 1, 1);
  REQUIRE(RotationStabilisation::applies(model));
  const State state = random_state(model, 7, 0.005, rotation, 2.5);
  RotationStabilisation stab(model);
  const Energy energy = [&](const State& s) { return stab.energy(s); };
  const int n = model.dof_count();
  auto unit_scale = [](int k) { return k % 6 < 3 ? kLength : 1.0; };

  std::vector<double> g(n, 0.0);
  const double w = stab.add_gradient(state, g.data());
  REQUIRE(w > 0);
  REQUIRE(w == Approx(stab.energy(state)).epsilon(1e-13));
  // Gradient against central differences (support/finite_difference.hpp: h ~ cbrt(eps) per unit
  // of the DOF's scale, error ~ 1e-10 relative; 1e-6 of |g| leaves room for the third derivative).
  double g_scale = 0;
  for (int k = 0; k < n; ++k) g_scale = std::max(g_scale, std::abs(g[k]) * unit_scale(k));
  for (int k = 0; k < n; ++k) {
    std::vector<double> e(n, 0.0);
    e[k] = unit_scale(k);
    const double fd = directional_derivative(model, energy, state, e);
    INFO("dof " << k << " fd " << fd << " analytic " << g[k] * e[k]);
    REQUIRE(std::abs(fd - g[k] * e[k]) <= 1e-6 * g_scale);
  }

  // Every entry of the assembled tangent, the diagonal blocks and the product against mixed
  // second differences (h ~ eps^(1/4), error ~ sqrt(eps) of the largest scaled entry; 1e-5).
  stab.prepare(state);
  std::vector<Eigen::Triplet<double>> triplets;
  stab.add_triplets(triplets);
  Eigen::SparseMatrix<double> K(n, n);
  K.setFromTriplets(triplets.begin(), triplets.end());
  const Eigen::MatrixXd dense = Eigen::MatrixXd(K);
  std::vector<double> blocks(36 * model.frame_count(), 0.0);
  stab.add_diagonal_blocks(blocks.data());
  double k_max = 0;
  for (int k = 0; k < n; ++k)
    for (int l = 0; l < n; ++l) k_max = std::max(k_max, std::abs(dense(k, l)) * unit_scale(k) * unit_scale(l));
  REQUIRE(k_max > 0);
  for (int k = 0; k < n; ++k)
    for (int l = k; l < n; ++l) {
      std::vector<double> ek(n, 0.0), el(n, 0.0);
      ek[k] = unit_scale(k), el[l] = unit_scale(l);
      const double fd = mixed_second_derivative(model, energy, state, ek, el);
      INFO("entry " << k << ", " << l << " fd " << fd << " assembled " << dense(k, l) * ek[k] * el[l]);
      REQUIRE(std::abs(fd - dense(k, l) * ek[k] * el[l]) <= 1e-5 * k_max);
      REQUIRE(dense(k, l) == Approx(dense(l, k)).margin(1e-12 * k_max / (unit_scale(k) * unit_scale(l))));
      if (k / 6 == l / 6) REQUIRE(blocks[36 * (k / 6) + 6 * (k % 6) + l % 6] == Approx(dense(k, l)).margin(1e-14 * k_max));
    }
  const std::vector<double> d = random_direction(model, 3, kLength);
  std::vector<double> kd(n, 0.0);
  stab.add_tangent(d.data(), kd.data());
  const Eigen::VectorXd kd_matrix = K * Eigen::Map<const Eigen::VectorXd>(d.data(), n);
  for (int k = 0; k < n; ++k) REQUIRE(kd_matrix[k] == Approx(kd[k]).margin(1e-12 * norm(kd)));
}

TEST_CASE("rotation stabilisation is invariant under rigid motions and zero when frames turn with the material",
          "[mechanics][rotation_stabilisation][invariance]") {
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk, 2, 2, 1);
  RotationStabilisation stab(model);
  const State state = random_state(model, 11, 0.004, 0.3);
  const double w = stab.energy(state);
  REQUIRE(w > 0);
  // A rigid motion (rotation Q about a skew axis, translation t) of the whole configuration:
  // R_i -> Q R_i, so R_i^T R_j and the energy do not change.
  const Vec3 r{0.4, -1.1, 0.7}, t{0.3, -0.2, 0.5};
  const Quat q = quat_exp(r);
  const Mat3 Q = rotation_matrix(q);
  State moved = state;
  for (int i = 0; i < model.frame_count(); ++i) {
    store3(&moved.positions[3 * i], Q * load3(&state.positions[3 * i]) + t);
    store_quat(&moved.orientations[4 * i], normalized(q * load_quat(&state.orientations[4 * i])));
  }
  REQUIRE(stab.energy(moved) == Approx(w).epsilon(1e-12));
  // A rigid rotation of the rest state: every R_i^T R_j = I.
  State rigid = rest_state(model);
  for (int i = 0; i < model.frame_count(); ++i) {
    store3(&rigid.positions[3 * i], Q * load3(&rigid.positions[3 * i]) + t);
    store_quat(&rigid.orientations[4 * i], q);
  }
  REQUIRE(std::abs(stab.energy(rigid)) <= 1e-28);
}

TEST_CASE("rotation stabilisation stiffens the zero-energy modes of frame hexahedra", "[mechanics][rotation_stabilisation]") {
  // The frames of one x-layer of a hexahedral grid turning together about x (no translation)
  // leave sum_i w_i (x_i + R_i l_i) unchanged at every point: a null vector of the elastic
  // tangent at rest. It twists each x-edge from the layer to its neighbour layers by the layer's
  // angle theta: tau = -2 sin(theta), W = k/8 tau^2 ~ k theta^2 / 2, so d^T K d = sum k_e over
  // those edges; the y- and z-edges inside the layer keep R_i^T R_j = I.
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk, 3, 2, 2);
  const State rest = rest_state(model);
  const int n = model.dof_count();
  const double layer_x = 0.2 / 3;  // the second of four x-layers of frames
  std::vector<double> d(n, 0.0);
  std::vector<std::uint8_t> in_layer(model.frame_count(), 0);
  for (int i = 0; i < model.frame_count(); ++i)
    if (std::abs(model.frame_rest_positions[3 * i] - layer_x) < 1e-9) {
      in_layer[i] = 1;
      d[6 * i + 3] = 1.0;
    }
  REQUIRE(std::count(in_layer.begin(), in_layer.end(), 1) == 9);

  Elasticity elasticity(model);
  elasticity.prepare(rest);
  std::vector<double> kd(n, 0.0);
  elasticity.apply_tangent(d.data(), kd.data());
  // Elastic stiffness of a single frame's rotation, for scale: the same d on one frame only.
  std::vector<double> one(n, 0.0), k_one(n, 0.0);
  for (int i = 0; i < model.frame_count(); ++i)
    if (in_layer[i]) {
      one[6 * i + 3] = 1.0;
      break;
    }
  elasticity.apply_tangent(one.data(), k_one.data());
  REQUIRE(dot(one, k_one) > 0);
  // Round-off of sums of O(mu v) terms: 1e-12 of one frame's rotational stiffness.
  REQUIRE(std::abs(dot(d, kd)) <= 1e-12 * dot(one, k_one));

  RotationStabilisation stab(model);
  stab.prepare(rest);
  std::vector<double> sd(n, 0.0);
  stab.add_tangent(d.data(), sd.data());
  // Each x-edge from the layer belongs to the hexahedra around it (1, 2 or 4 of the 3 x 2 x 2
  // cells), each of whose 8 samples gives kappa mu v_s / 12: k_e = kappa mu V_cells / 12.
  const double mu = model.materials[0].mu;
  const double cell = (0.2 / 3) * (0.1 / 2) * (0.05 / 2);
  double expected = 0;
  for (int i = 0; i < model.frame_count(); ++i) {
    if (!in_layer[i]) continue;
    const double y = model.frame_rest_positions[3 * i + 1], z = model.frame_rest_positions[3 * i + 2];
    const int cells_y = (y < 1e-9 || y > 0.1 - 1e-9) ? 1 : 2, cells_z = (z < 1e-9 || z > 0.05 - 1e-9) ? 1 : 2;
    expected += 2 * kRotationStabilisation * mu * cells_y * cells_z * cell / 12;  // two x-edges
  }
  REQUIRE(expected > 0);
  REQUIRE(dot(d, sd) == Approx(expected).epsilon(1e-12));
  // A rotation of the layer about y (bending) keeps the x-edges untwisted (e . u = 0) and twists
  // the y-edges inside the layer not at all: no stiffness from the term.
  std::vector<double> bend(n, 0.0), sb(n, 0.0);
  for (int i = 0; i < model.frame_count(); ++i)
    if (in_layer[i]) bend[6 * i + 4] = 1.0;
  stab.add_tangent(bend.data(), sb.data());
  REQUIRE(std::abs(dot(bend, sb)) <= 1e-14 * expected);
}

TEST_CASE("rotation stabilisation applies to hexahedra with free rotations only", "[mechanics][rotation_stabilisation]") {
  REQUIRE_FALSE(RotationStabilisation::applies(small_box_model(CellType::tetrahedron)));
  Model fem = small_box_model(CellType::hexahedron);
  lock_rotations(fem);
  REQUIRE_FALSE(RotationStabilisation::applies(fem));
}
