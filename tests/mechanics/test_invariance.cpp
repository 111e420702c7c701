// Rigid-motion invariance and the affine patch test.
#include "core/rotation.hpp"
#include "mechanics/elasticity.hpp"
#include "mechanics/frame_sample.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::test;

namespace {

// Applies x -> Q x + t to every frame and R -> Q R.
State rigidly_moved(const State& s, const Vec3& rotation, const Vec3& t) {
  State m = s;
  const Quat q = quat_exp(rotation);
  const Mat3 Q = rotation_matrix(q);
  for (int i = 0; i < s.frame_count(); ++i) {
    store3(&m.positions[3 * i], Q * load3(&s.positions[3 * i]) + t);
    store_quat(&m.orientations[4 * i], normalized(q * load_quat(&s.orientations[4 * i])));
  }
  return m;
}

}  // namespace

TEST_CASE("rigid motions of the rest state give zero energy and zero force", "[mechanics][invariance]") {
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const double angle = GENERATE(0.5, 2.0, 3.0);
  const Model model = small_box_model(type, law);
  const State moved = rigidly_moved(rest_state(model), angle * Vec3{0.6, 0.0, 0.8}, Vec3{1.0, -2.0, 0.5});
  Elasticity elasticity(model);
  std::vector<double> g(model.dof_count());
  const double w = elasticity.gradient(moved, g.data());
  // Energy scale: E * volume ~ 1e4 * 1e-3 = 10 J; round-off after rotating: ~1e-15 relative.
  REQUIRE(std::abs(w) <= 1e-12);
  for (double x : g) REQUIRE(std::abs(x) <= 1e-9);  // forces scale E * area ~ 1e2 N
}

TEST_CASE("a rigid motion of a deformed state leaves energy unchanged and rotates forces", "[mechanics][invariance]") {
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk);
  const State state = random_state(model, 21, 0.02, 0.8, 0.0);
  const Vec3 rot{1.1, -0.4, 2.0};
  const State moved = rigidly_moved(state, rot, Vec3{0.3, 0.1, -0.7});
  Elasticity elasticity(model);
  std::vector<double> g(model.dof_count()), gm(model.dof_count());
  const double w = elasticity.gradient(state, g.data());
  const double wm = elasticity.gradient(moved, gm.data());
  REQUIRE(wm == Approx(w).epsilon(1e-12));
  const Mat3 Q = rotation_matrix(quat_exp(rot));
  for (int i = 0; i < model.frame_count(); ++i) {
    REQUIRE(norm(Q * load3(&g[6 * i]) - load3(&gm[6 * i])) <= 1e-10 * norm(g));
    REQUIRE(norm(Q * load3(&g[6 * i + 3]) - load3(&gm[6 * i + 3])) <= 1e-10 * norm(g));
  }
  // Translation invariance: the translational forces sum to zero.
  Vec3 sum{0, 0, 0};
  for (int i = 0; i < model.frame_count(); ++i) sum += load3(&g[6 * i]);
  REQUIRE(norm(sum) <= 1e-10 * norm(g));
}

TEST_CASE("affine patch test: an affine frame field gives F = A everywhere and no interior force", "[mechanics][patch]") {
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model model = small_box_model(type, MaterialLaw::stvk, 3, 3, 3);
  const Mat3 A = Mat3{{{1.1, 0.05, -0.02}, {0.03, 0.95, 0.04}, {-0.01, 0.02, 1.05}}};
  const Vec3 t{0.01, -0.02, 0.03};
  State s = rest_state(model);
  for (int i = 0; i < model.frame_count(); ++i)
    store3(&s.positions[3 * i], A * load3(&model.frame_rest_positions[3 * i]) + t);
  std::vector<double> R;
  rotation_matrices(s, R);
  const NeighbourTable& nb = model.neighbours;
  const PairTableView view{nb.offsets.data(), nb.frames.data(), nb.weights.data(), nb.weight_gradients.data(),
                           nb.rest_offsets.data()};
  for (int sm = 0; sm < model.sample_count(); ++sm) {
    const Mat3 F = sample_deformation_gradient(view, sm, s.positions.data(), R.data());
    REQUIRE(ddot(F - A, F - A) <= 1e-26);
    const Vec3 p = sample_position(view, sm, s.positions.data(), R.data());
    REQUIRE(norm(p - (A * load3(&model.samples.rest_positions[3 * sm]) + t)) <= 1e-14);
  }
  Elasticity elasticity(model);
  std::vector<double> g(model.dof_count());
  elasticity.gradient(s, g.data());
  const double scale = norm(g);
  REQUIRE(scale > 0);
  int interior = 0;
  for (int i = 0; i < model.frame_count(); ++i) {
    const Vec3 x = load3(&model.frame_rest_positions[3 * i]);
    const bool inside = x.x > 1e-9 && x.x < 0.2 - 1e-9 && x.y > 1e-9 && x.y < 0.1 - 1e-9 && x.z > 1e-9 &&
                        x.z < 0.05 - 1e-9;
    if (!inside) continue;
    ++interior;
    REQUIRE(norm(load3(&g[6 * i])) <= 1e-12 * scale);
  }
  REQUIRE(interior == 8);
}
