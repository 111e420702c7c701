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
