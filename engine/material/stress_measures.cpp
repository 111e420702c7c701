#include "material/stress_measures.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

namespace fascia {

StressMeasures stress_measures(const Material& material, const Mat3& F) {
  StressMeasures out;
  out.green_strain = green_lagrange_strain(F);
  out.energy_density = energy_density(material, F);
  if (material.law == MaterialLaw::hgo) out.fibre_stretch = fibre_stretch(material.fibres, F);
  const double J = det(F);
  if (material.law == MaterialLaw::stvk) {
    out.second_piola = stvk_stress_from_strain<double>(material.lambda, material.mu, out.green_strain);
  } else if (J > 0) {
    MaterialCache cache;
    const Mat3 P = first_piola(material, F, cache);
    out.second_piola = transpose(inverse_transpose(F)) * P;  // S = F^{-1} P
  } else {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    out.second_piola = nan * identity3<double>();
  }
  if (J > 0) {
    out.cauchy = (1.0 / J) * (F * out.second_piola * transpose(F));
  } else {
    out.cauchy = std::numeric_limits<double>::quiet_NaN() * identity3<double>();
  }
  return out;
}

double von_mises(const Mat3& A) {
  Mat3 s = symmetric_part(A);
  const double mean = trace(s) / 3;
  for (int i = 0; i < 3; ++i) s.m[i][i] -= mean;
  return std::sqrt(1.5 * ddot(s, s));
}

std::array<double, 3> principal_values(const Mat3& A) {
  const Mat3 s = symmetric_part(A);
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m(i, j) = s.m[i][j];
  if (!m.allFinite()) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan, nan};
  }
  // Eigen's closed form (trigonometric roots of the characteristic cubic, 0.1 us against 0.5 for
  // its iterative QR, which is most of a sample's row): accurate to rounding of the largest
  // eigenvalue while the eigenvalues are apart; near a repeated one (uniaxial states) acos loses
  // digits, about eps max|l| / gap, so where two lie within kDirectGap of the largest the
  // iterative solver, accurate to rounding there too, decides.
  constexpr double kDirectGap = 1e-3;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(m, Eigen::EigenvaluesOnly);
  Eigen::Vector3d v = solver.eigenvalues();  // increasing
  const double largest = std::max(std::abs(v(0)), std::abs(v(2)));
  if (std::min(v(1) - v(0), v(2) - v(1)) < kDirectGap * largest)
    v = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(m, Eigen::EigenvaluesOnly).eigenvalues();
  return {v(2), v(1), v(0)};
}

}  // namespace fascia
