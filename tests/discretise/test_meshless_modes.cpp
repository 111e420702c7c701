// Zero-energy modes of the frame mechanics with meshless shape functions.
//
// With linear precision (MLS; also P1 tetrahedra and trilinear hexahedra), sum_i x_i grad w_i^T
// = I and sum_i w_i x_i = p, so rotating every frame by the same R about its own origin gives,
// by eq. (8), F = G + R (I - G) = I with G = sum_i x_i grad w_i^T, and leaves every sample where
// it was (eq. 3): three exact zero-energy modes beyond the six rigid motions. To first order,
// theta_i = a x_i (rotation vectors growing linearly from the origin, positions fixed) adds one
// more: dF = sum_i [a x_i]x (l_i grad w_i^T + w_i I) = -a sum_i [l_i]x l_i grad w_i^T = 0 with
// l_i = p - x_i. These modes are global: fixing the rotations of any frame (a clamp) removes them.
// Trilinear hexahedra
// have further local mechanisms (section twists, see the beam study); meshless ones have none.
#include "core/rotation.hpp"
#include "mechanics/assembled_tangent.hpp"
#include "study/meshless_beam.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"
#include "support/meshless_fixtures.hpp"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::test;

namespace {

// Eigenvalues (ascending) of the rest tangent in units where every DOF is a length: rotations
// are scaled by `length` (theta -> length * theta), so K~ = D K D, D = diag(1, 1, 1, 1/l, 1/l, 1/l)
// per frame, all entries in N/m.
Eigen::VectorXd rest_spectrum(const Model& model, double length) {
  Elasticity elasticity(model, 1);
  elasticity.prepare(rest_state(model));
  Eigen::MatrixXd K = Eigen::MatrixXd(assemble_tangent(elasticity));
  Eigen::VectorXd d(model.dof_count());
  for (int i = 0; i < model.dof_count(); ++i) d[i] = i % 6 < 3 ? 1.0 : 1.0 / length;
  K = d.asDiagonal() * K * d.asDiagonal();
  return Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(K, Eigen::EigenvaluesOnly).eigenvalues();
}

}  // namespace

// Counts eigenvalues below 1e-10 of the largest: the measured zero eigenvalues are round-off
// (|lambda| < 1e-16 lambda_max), the smallest elastic ones above 4e-4 lambda_max on these
// models, so the threshold sits in a gap of twelve orders.
int zero_modes(const Eigen::VectorXd& spectrum) {
  int zeros = 0;
  for (int i = 0; i < spectrum.size(); ++i) zeros += spectrum[i] < 1e-10 * spectrum.maxCoeff();
  return zeros;
}

TEST_CASE("meshless: the free-free rest tangent has the rigid modes, plus the frame-rotation modes",
          "[discretise][meshless][modes]") {
  const std::uint64_t seed = GENERATE(1, 2);
  const Model model = small_meshless_box(MaterialLaw::stvk, seed).model;
  const Eigen::VectorXd e = rest_spectrum(model, 0.04);  // rotations scaled by r_f
  const int zeros = zero_modes(e);
  INFO("zero modes " << zeros << ", next " << e[zeros] / e.maxCoeff());
  REQUIRE(zeros == 10);
  REQUIRE(e[zeros] > 1e-5 * e.maxCoeff());
}

TEST_CASE("the same count for P1 tetrahedra; trilinear hexahedra have more (section twists)",
          "[discretise][meshless][modes]") {
  REQUIRE(zero_modes(rest_spectrum(small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 4, 2, 2), 0.05)) == 10);
  REQUIRE(zero_modes(rest_spectrum(small_box_model(CellType::hexahedron, MaterialLaw::stvk, 4, 2, 2), 0.05)) > 10);
}

TEST_CASE("meshless MLS: one rotation of every frame about its own origin is an exact zero-energy mode",
          "[discretise][meshless][modes]") {
  const Model model = small_meshless_box().model;
  State state = rest_state(model);
  const Quat q = quat_exp(Vec3{0.7, -0.3, 1.2});  // 1.4 rad
  for (int i = 0; i < model.frame_count(); ++i) store_quat(&state.orientations[4 * i], q);
  Elasticity elasticity(model, 1);
  // Energy scale: E V = 1e4 Pa * 1e-3 m^3 = 10 J; round-off only.
  const double w = elasticity.energy(state);
  INFO("energy " << w << " J");
  REQUIRE(std::abs(w) <= 1e-11);
}

TEST_CASE("meshless MLS: rotation vectors growing linearly from the origin are a first-order zero mode",
          "[discretise][meshless][modes]") {
  const Model model = small_meshless_box().model;
  Elasticity elasticity(model, 1);
  elasticity.prepare(rest_state(model));
  // v: theta_i = x_i / (1 m), positions fixed. t: a rotation field of the same size that is not
  // a mode (theta_i = a permutation of x_i), for the scale of K times such a field.
  std::vector<double> v(model.dof_count(), 0.0), t(model.dof_count(), 0.0);
  std::vector<double> kv(model.dof_count()), kt(model.dof_count());
  for (int i = 0; i < model.frame_count(); ++i)
    for (int k = 0; k < 3; ++k) {
      v[6 * i + 3 + k] = model.frame_rest_positions[3 * i + k];
      t[6 * i + 3 + k] = model.frame_rest_positions[3 * i + (k + 1) % 3];
    }
  elasticity.apply_tangent(v.data(), kv.data());
  elasticity.apply_tangent(t.data(), kt.data());
  // Round-off: |K v| ~ 1e-16 lambda_max |v| against |K t| ~ 1e-3 lambda_max |t| or more.
  INFO("|K v| " << norm(kv) << ", |K t| " << norm(kt));
  REQUIRE(norm(kv) <= 1e-9 * norm(kt));
}

TEST_CASE("meshless: the clamped cantilever tangent is positive definite (no mechanism)",
          "[discretise][meshless][modes]") {
  const double rf = 1.0;  // 16 x 1 x 1 m beam, about 30 frames
  const Model model = build_meshless_beam(BeamSettings{}, rf).model;
  Elasticity elasticity(model, 1);
  elasticity.prepare(rest_state(model));
  const Eigen::MatrixXd K = Eigen::MatrixXd(assemble_tangent(elasticity));
  std::vector<int> free;
  for (int i = 0; i < model.dof_count(); ++i)
    if (!model.fixed_dofs[i]) free.push_back(i);
  const int n = static_cast<int>(free.size());
  Eigen::MatrixXd Kf(n, n);
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) Kf(a, b) = K(free[a], free[b]) / ((free[a] % 6 < 3 ? 1 : rf) * (free[b] % 6 < 3 ? 1 : rf));
  const Eigen::VectorXd e = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Kf, Eigen::EigenvaluesOnly).eigenvalues();
  // Measured lambda_min / lambda_max: 6.9e-7 (MLS, consistent integration), the bending of a slender
  // beam (P1 tetrahedra 16x1x1: 6e-7); a mechanism would give round-off, below 1e-15.
  INFO("lambda_min / lambda_max " << e[0] / e.maxCoeff());
  REQUIRE(e[0] > 1e-8 * e.maxCoeff());
}
