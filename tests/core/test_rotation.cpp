#include "core/rotation.hpp"

#include <catch2/catch.hpp>

#include <random>

using namespace fascia;

TEST_CASE("quaternion exponential and logarithm are inverse and give rotations", "[core]") {
  const double angle = GENERATE(0.0, 1e-9, 1e-5, 0.3, 2.0, 3.1);
  const Vec3 axis{0.48, -0.6, 0.64};  // unit
  const Vec3 v = angle * axis;
  const Quat q = quat_exp(v);
  REQUIRE(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z == Approx(1.0).epsilon(1e-15));
  const Vec3 back = quat_log(q);
  REQUIRE(norm(back - v) <= 1e-12 * (1 + angle));
  const Mat3 R = rotation_matrix(q);
  const Mat3 RtR = transpose(R) * R;
  REQUIRE(ddot(RtR - identity3(), RtR - identity3()) <= 1e-28);
  REQUIRE(det(R) == Approx(1.0).epsilon(1e-14));
  REQUIRE(norm(R * axis - axis) <= 1e-14);  // the axis is fixed
}

TEST_CASE("world-axis increments compose as exp([dr]x) R", "[core]") {
  const Quat q = normalized(Quat{0.7, 0.1, -0.4, 0.3});
  const Vec3 dr{1e-3, -2e-3, 0.5e-3};
  const Mat3 lhs = rotation_matrix(apply_increment(q, dr));
  // exp([dr]x) to second order plus the exact R: compare with the matrix exponential via quat.
  const Mat3 rhs = rotation_matrix(quat_exp(dr)) * rotation_matrix(q);
  REQUIRE(ddot(lhs - rhs, lhs - rhs) <= 1e-28);
}

TEST_CASE("quaternions stay unit over a million increments", "[core]") {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  Quat q{1, 0, 0, 0};
  for (int k = 0; k < 1000000; ++k) q = apply_increment(q, Vec3{u(rng), u(rng), u(rng)});
  REQUIRE(std::abs(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z - 1.0) <= 4e-16);
}

TEST_CASE("an increment turned from one orientation to another: Q = R(q) R(q_ref)^T, its transpose undoes it",
          "[core]") {
  const Quat q = normalized(Quat{0.7, 0.1, -0.4, 0.3}), q_ref = normalized(Quat{-0.2, 0.9, 0.1, 0.35});
  const double x[6] = {1.0, -2.0, 0.5, 0.25, 3.0, -1.5};
  double y[6], back[6];
  rotate_increment(q, q_ref, x, y, false);
  const Mat3 Q = rotation_matrix(q) * transpose(rotation_matrix(q_ref));
  for (int h = 0; h < 6; h += 3) {
    const Vec3 expected = Q * Vec3{x[h], x[h + 1], x[h + 2]};
    REQUIRE(norm(Vec3{y[h], y[h + 1], y[h + 2]} - expected) <= 1e-14 * norm(expected));
  }
  // In place, then back with the transpose: the input to round-off.
  for (int k = 0; k < 6; ++k) back[k] = y[k];
  rotate_increment(q, q_ref, back, back, true);
  for (int k = 0; k < 6; ++k) REQUIRE(std::abs(back[k] - x[k]) <= 1e-14 * 4);
  // Equal orientations: the identity.
  rotate_increment(q, q, x, y, false);
  for (int k = 0; k < 6; ++k) REQUIRE(std::abs(y[k] - x[k]) <= 1e-15 * 4);
}

TEST_CASE("polar_rotation recovers R of A = R U from identity and from far guesses, at any scale of A", "[core]") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Quat q_true = normalized(Quat{u(rng), u(rng), u(rng), u(rng)});
    // U = V diag(s) V^T with stretches s in [0.5, 2]: symmetric positive definite.
    const Mat3 V = rotation_matrix(normalized(Quat{u(rng), u(rng), u(rng), u(rng)}));
    Mat3 S = zero3<double>();
    for (int k = 0; k < 3; ++k) S.m[k][k] = 1.25 + 0.75 * u(rng);
    const double scale = trial % 2 ? 1e-12 : 1e3;  // sums of w v F are volumes: m^3
    const Mat3 A = scale * (rotation_matrix(q_true) * (V * S * transpose(V)));
    const Quat guess = trial % 3 == 0 ? Quat{1, 0, 0, 0} : normalized(Quat{u(rng), u(rng), u(rng), u(rng)});
    const Quat q = polar_rotation(A, guess);
    // The angle between q and q_true. The iteration stops once its turn |omega| is below 1e-9
    // rad; it converges linearly, slower the more U's stretches differ (here by up to 4x), and
    // the turns it leaves, sum_k rho^k |omega| at rate rho, stay below 100 |omega| for rho < 0.99.
    // From a guess up to pi away the 64 turns allowed reach that here (32 would not).
    REQUIRE(norm(quat_log(q * conjugate(q_true))) <= 1e-7);
  }
  // A = 0: the guess.
  const Quat g = normalized(Quat{0.3, 0.2, 0.1, 0.9});
  const Quat q = polar_rotation(zero3<double>(), g);
  REQUIRE((q.w == g.w && q.x == g.x && q.y == g.y && q.z == g.z));
}
