// The frames' material rotations (mechanics/material_rotation.hpp) of the CPU Elasticity.
#include "core/rotation.hpp"
#include "mechanics/elasticity.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::test;

namespace {

std::vector<double> material_rotations(const Model& model, const State& s) {
  Elasticity elasticity(model, 1);
  elasticity.prepare(s);
  std::vector<double> q(4 * static_cast<size_t>(model.frame_count()));
  elasticity.material_rotations(q.data());
  return q;
}

// The angle (rad) of the rotation from b to a.
double angle_between(const Quat& a, const Quat& b) { return norm(quat_log(a * conjugate(b))); }

}  // namespace

TEST_CASE("a homogeneous deformation x -> R U x gives every frame the material rotation R", "[mechanics]") {
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model model = small_box_model(type, MaterialLaw::stvk, 3, 2, 2);
  // The affine patch test's field (test_invariance.cpp) with A = R U: F_s = R U at every sample,
  // so A_i = (sum_s w_is v_s) R U, whose polar rotation is R; the frames' own orientations stay
  // identity and are only the iteration's start.
  const Quat r = quat_exp(Vec3{0.9, -0.4, 1.3});
  const Mat3 U{{{1.2, 0.1, 0.0}, {0.1, 0.9, -0.05}, {0.0, -0.05, 1.1}}};
  const Mat3 A = rotation_matrix(r) * U;
  State s = rest_state(model);
  for (int i = 0; i < model.frame_count(); ++i)
    store3(&s.positions[3 * i], A * load3(&model.frame_rest_positions[3 * i]));
  const std::vector<double> q = material_rotations(model, s);
  for (int i = 0; i < model.frame_count(); ++i) {
    INFO("frame " << i);
    // polar_rotation stops at a turn below 1e-9 rad.
    REQUIRE(angle_between(load_quat(&q[4 * i]), r) <= 1e-8);
  }
}

TEST_CASE("the frames' material rotations turn with a rigid turn of the model", "[mechanics][invariance]") {
  const Model model = small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 3, 2, 2);
  const State s = random_state(model, 11, 0.004, 0.3);
  const double turn = 2.4;  // rad, about random_state's axis (0.3, -0.5, 0.8)
  const State turned = random_state(model, 11, 0.004, 0.3, turn);
  const Vec3 axis{0.3, -0.5, 0.8};
  const Quat Q = quat_exp((turn / norm(axis)) * axis);
  const std::vector<double> q = material_rotations(model, s), q_turned = material_rotations(model, turned);
  for (int i = 0; i < model.frame_count(); ++i) {
    INFO("frame " << i);
    REQUIRE(angle_between(load_quat(&q_turned[4 * i]), Q * load_quat(&q[4 * i])) <= 1e-8);
  }
}
