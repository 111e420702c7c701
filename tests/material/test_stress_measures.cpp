// Strain and stress measures for output: analytic uniaxial stretch, consistency with the laws'
// first Piola-Kirchhoff stress, objectivity, the scalar measures of known tensors, and principal
// values against Eigen's eigensolver.
#include "core/rotation.hpp"
#include "material/stress_measures.hpp"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

using namespace fascia;

namespace {

double max_abs_difference(const Mat3& a, const Mat3& b) {
  double d = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) d = std::max(d, std::abs(a.m[i][j] - b.m[i][j]));
  return d;
}

const Mat3 kF{{{1.10, 0.05, -0.02}, {0.03, 0.95, 0.04}, {-0.01, 0.02, 1.05}}};

}  // namespace

TEST_CASE("stress measures of a uniaxial StVK stretch match the closed form", "[material]") {
  const Material m = make_material(MaterialLaw::stvk, 40e3, 0.3, 1000);
  const double l = 1.2;
  const StressMeasures s = stress_measures(m, Mat3{{{l, 0, 0}, {0, 1, 0}, {0, 0, 1}}});
  const double e = 0.5 * (l * l - 1);
  const double S11 = (m.lambda + 2 * m.mu) * e, S22 = m.lambda * e;
  // Values are O(1e4) Pa from a few multiplications: rounding is below 1e-10 relative.
  CHECK(s.green_strain.m[0][0] == Approx(e));
  CHECK(s.green_strain.m[1][1] == 0);
  CHECK(s.second_piola.m[0][0] == Approx(S11).epsilon(1e-12));
  CHECK(s.second_piola.m[1][1] == Approx(S22).epsilon(1e-12));
  // sigma = F S F^T / J with J = l: sigma11 = l S11, sigma22 = S22 / l.
  CHECK(s.cauchy.m[0][0] == Approx(l * S11).epsilon(1e-12));
  CHECK(s.cauchy.m[1][1] == Approx(S22 / l).epsilon(1e-12));
  CHECK(s.energy_density == Approx(0.5 * m.lambda * e * e + m.mu * e * e).epsilon(1e-12));
  // Principal values, largest first; von Mises of diag(a, b, b) is |a - b|.
  const auto p = principal_values(s.cauchy);
  CHECK(p[0] == Approx(l * S11).epsilon(1e-12));
  CHECK(p[1] == Approx(S22 / l).epsilon(1e-12));
  CHECK(p[2] == Approx(S22 / l).epsilon(1e-12));
  CHECK(von_mises(s.cauchy) == Approx(l * S11 - S22 / l).epsilon(1e-12));
}

TEST_CASE("stress measures agree with the law's P and are objective", "[material]") {
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const Material m = make_material(law, 40e3, 0.45, 1000);
  const StressMeasures s = stress_measures(m, kF);
  MaterialCache cache;
  const Mat3 P = first_piola(m, kF, cache);
  // P = F S and sigma = P F^T / J, to rounding of O(1e4) Pa values (1e-12 relative, 1e-7 Pa).
  CHECK(max_abs_difference(kF * s.second_piola, P) < 1e-7);
  CHECK(max_abs_difference(s.cauchy, (1 / det(kF)) * (P * transpose(kF))) < 1e-7);
  CHECK(max_abs_difference(s.second_piola, transpose(s.second_piola)) < 1e-7);
  CHECK(max_abs_difference(s.cauchy, transpose(s.cauchy)) < 1e-7);
  CHECK(s.energy_density == Approx(energy_density(m, kF)));
  // A rotation Q after the deformation: E, S unchanged, sigma -> Q sigma Q^T, scalars unchanged.
  const Mat3 Q = rotation_matrix(quat_exp(Vec3{0.4, -1.1, 0.7}));
  const StressMeasures r = stress_measures(m, Q * kF);
  CHECK(max_abs_difference(r.green_strain, s.green_strain) < 1e-14);
  CHECK(max_abs_difference(r.second_piola, s.second_piola) < 1e-7);
  CHECK(max_abs_difference(r.cauchy, Q * s.cauchy * transpose(Q)) < 1e-7);
  CHECK(von_mises(r.cauchy) == Approx(von_mises(s.cauchy)).epsilon(1e-10));
  const auto a = principal_values(r.cauchy), b = principal_values(s.cauchy);
  for (int k = 0; k < 3; ++k) CHECK(a[k] == Approx(b[k]).epsilon(1e-10).margin(1e-7));
  // At rest everything vanishes.
  const StressMeasures zero = stress_measures(m, identity3<double>());
  CHECK(max_abs_difference(zero.cauchy, zero3()) < 1e-9);
  CHECK(zero.energy_density == Approx(0).margin(1e-12));
}

TEST_CASE("von Mises and principal values of known tensors", "[material]") {
  const Mat3 hydrostatic{{{-5, 0, 0}, {0, -5, 0}, {0, 0, -5}}};
  CHECK(von_mises(hydrostatic) == Approx(0).margin(1e-12));
  // Pure shear tau: von Mises sqrt(3) tau, principal values tau, 0, -tau.
  const Mat3 shear{{{0, 2, 0}, {2, 0, 0}, {0, 0, 0}}};
  CHECK(von_mises(shear) == Approx(2 * std::sqrt(3.0)));
  const auto p = principal_values(shear);
  CHECK(p[0] == Approx(2));
  CHECK(p[1] == Approx(0).margin(1e-14));
  CHECK(p[2] == Approx(-2));
  // An inverted neo-Hookean point has no stress: NaN, not a crash.
  const Material nh = make_material(MaterialLaw::neo_hookean, 40e3, 0.3, 1000);
  const StressMeasures s = stress_measures(nh, Mat3{{{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}});
  CHECK(std::isnan(s.cauchy.m[0][0]));
  CHECK(std::isnan(principal_values(s.cauchy)[0]));
}

TEST_CASE("principal values of rotated diagonal tensors, with eigenvalues apart and nearly repeated", "[material]") {
  // Q diag(l) Q^T formed in double moves the eigenvalues by a few eps max|l| (Weyl); the closed
  // form adds about eps max|l| / gap where the eigenvalues are apart by gap >= 1e-3 max|l|, the
  // iterative solver closer ones to rounding: 1e-12 of max|l| bounds both with room.
  const double gaps[] = {2.0, 1e-2, 2e-3, 9e-4, 1e-6, 1e-10, 0.0};
  int k = 0;
  for (const double gap : gaps)
    for (const double scale : {1e-6, 1.0, 3e4}) {
      const Mat3 Q = rotation_matrix(quat_exp(Vec3{0.3 + 0.1 * k, -1.1 + 0.07 * k, 0.7 - 0.05 * k}));
      ++k;
      const double l[3] = {scale * (1.5 + gap), scale * 1.5, -0.4 * scale};
      const Mat3 D{{{l[1], 0, 0}, {0, l[2], 0}, {0, 0, l[0]}}};
      const auto p = principal_values(Q * D * transpose(Q));
      CAPTURE(gap, scale);
      for (int i = 0; i < 3; ++i) CHECK(std::abs(p[i] - l[i]) <= 1e-12 * 1.5 * scale * (1 + gap));
    }
}

TEST_CASE("principal values of random symmetric tensors equal Eigen's iterative eigensolver's", "[material]") {
  // Both accurate to a few eps of the largest eigenvalue (the closed form where the eigenvalues are
  // apart, Jacobi rotations otherwise; Eigen's QR): 1e-13 of it bounds their difference.
  std::mt19937 rng(3);
  std::normal_distribution<double> n;
  int near_repeated = 0;
  for (int k = 0; k < 20000; ++k) {
    Mat3 A;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) A.m[i][j] = n(rng);
    if (k % 4 == 0) {  // two eigenvalues within 1e-5 of each other
      const Mat3 Q = rotation_matrix(quat_exp(Vec3{n(rng), n(rng), n(rng)}));
      const double a = n(rng), b = a + 1e-5 * n(rng), c = n(rng);
      A = Q * Mat3{{{a, 0, 0}, {0, b, 0}, {0, 0, c}}} * transpose(Q);
      ++near_repeated;
    }
    Eigen::Matrix3d m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m(i, j) = 0.5 * (A.m[i][j] + A.m[j][i]);
    const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m, Eigen::EigenvaluesOnly).eigenvalues();
    const auto p = principal_values(A);
    const double largest = e.cwiseAbs().maxCoeff();
    CAPTURE(k);
    for (int i = 0; i < 3; ++i) REQUIRE(std::abs(p[static_cast<size_t>(i)] - e(2 - i)) <= 1e-13 * largest);
  }
  CHECK(near_repeated == 5000);
}
