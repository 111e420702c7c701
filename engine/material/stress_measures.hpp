// Strain and stress measures of a material point for output (HDF5 fields, ParaView), from its
// deformation gradient F and the constitutive law (material.hpp), all in SI units:
//   E     = 1/2 (F^T F - I)              Green-Lagrange strain (eq. 5), dimensionless
//   S     = F^{-1} P                     second Piola-Kirchhoff stress (eq. 19 for StVK), Pa
//   sigma = J^{-1} P F^T = J^{-1} F S F^T  Cauchy (true) stress, J = det F, Pa
//   psi                                  strain energy density per rest volume, J/m^3
// von Mises: sqrt(3/2 s : s), s = A - tr(A)/3 I (the deviator), for any symmetric A; principal
// values: the eigenvalues of a symmetric A, largest first.
//   lambda_f = |F a|                     fibre stretch of a law with fibres along its (mean)
//                                        direction a (hgo.hpp), 0 without
// FASCIA_HD: the host's output rows and the device's (kernels/device_sample_fields.hpp) run the
// same code.
#pragma once

#include "material/material.hpp"

#include <array>
#include <cmath>
#include <limits>

namespace fascia {

struct StressMeasures {
  Mat3 green_strain;   // E
  Mat3 second_piola;   // S, Pa
  Mat3 cauchy;         // sigma, Pa
  double energy_density = 0;  // psi, J/m^3
  double fibre_stretch = 0;   // |F a| (hgo), 0 for a law without fibres
};

// @pre det F > 0 for the Cauchy stress and the neo-Hookean law (an inverted sample has no Cauchy
// stress; StVK's E, S and psi are still defined and are returned, with sigma = NaN).
FASCIA_HD StressMeasures stress_measures(const Material& material, const Mat3& F) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
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
    out.second_piola = nan * identity3<double>();
  }
  out.cauchy = J > 0 ? (1.0 / J) * (F * out.second_piola * transpose(F)) : nan * identity3<double>();
  return out;
}

// sqrt(3/2 dev(A) : dev(A)) for a symmetric A (Pa for a stress).
FASCIA_HD double von_mises(const Mat3& A) {
  Mat3 s = symmetric_part(A);
  const double mean = trace(s) / 3;
  for (int i = 0; i < 3; ++i) s.m[i][i] -= mean;
  return std::sqrt(1.5 * ddot(s, s));
}

namespace stress_measures_detail {

// The eigenvalues of the symmetric S by cyclic Jacobi rotations (Golub & Van Loan, Matrix
// Computations, 4th ed., §8.5; the rotation of Numerical Recipes' jacobi), until the off-diagonal
// part is below rounding of the largest diagonal entry: accurate to rounding with repeated
// eigenvalues too. d: the eigenvalues, unordered.
FASCIA_HD void jacobi_eigenvalues(const Mat3& S, double (&d)[3]) {
  d[0] = S.m[0][0], d[1] = S.m[1][1], d[2] = S.m[2][2];
  double o[3] = {S.m[0][1], S.m[0][2], S.m[1][2]};  // entries (0, 1), (0, 2), (1, 2)
  constexpr int p_of[3] = {0, 0, 1}, q_of[3] = {1, 2, 2};
  constexpr int rp_of[3] = {1, 0, 0}, rq_of[3] = {2, 2, 1};  // the other entries of rows p and q
  for (int sweep = 0; sweep < 32; ++sweep) {
    const double big = std::fmax(std::fabs(d[0]), std::fmax(std::fabs(d[1]), std::fabs(d[2])));
    if (o[0] * o[0] + o[1] * o[1] + o[2] * o[2] <= 1e-33 * big * big) return;
    for (int k = 0; k < 3; ++k) {
      const double apq = o[k];
      if (apq == 0) continue;
      const int p = p_of[k], q = q_of[k];
      const double h = d[q] - d[p];
      double t;  // tan of the rotation angle
      if (std::fabs(h) + 100 * std::fabs(apq) == std::fabs(h)) {
        t = apq / h;
      } else {
        const double theta = 0.5 * h / apq;
        t = 1 / (std::fabs(theta) + std::sqrt(1 + theta * theta));
        if (theta < 0) t = -t;
      }
      const double c = 1 / std::sqrt(1 + t * t), s = t * c, tau = s / (1 + c);
      d[p] -= t * apq;
      d[q] += t * apq;
      o[k] = 0;
      const double g = o[rp_of[k]], e = o[rq_of[k]];  // (r, p) and (r, q), r the third index
      o[rp_of[k]] = g - s * (e + g * tau);
      o[rq_of[k]] = e + s * (g - e * tau);
    }
  }
}

}  // namespace stress_measures_detail

// Eigenvalues of the symmetric part of A, in decreasing order (NaN where A is not finite).
// The closed form (the characteristic cubic's trigonometric roots, Smith 1961, shifted by the mean
// and scaled) is accurate to rounding of the largest eigenvalue while the eigenvalues are apart;
// near a repeated one (uniaxial states) acos loses digits, about eps max|l| / gap, so where two lie
// within kDirectGap of the largest, Jacobi rotations decide. Not Eigen's SelfAdjointEigenSolver:
// in device code (CUDA 13, Eigen 3.4) it returned wrong eigenvalues.
FASCIA_HD std::array<double, 3> principal_values(const Mat3& A) {
  const Mat3 S = symmetric_part(A);
  bool finite = true;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) finite = finite && std::isfinite(S.m[i][j]);
  if (!finite) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan, nan};
  }
  constexpr double kDirectGap = 1e-3;
  double l[3];
  const double q = trace(S) / 3;
  const double off = S.m[0][1] * S.m[0][1] + S.m[0][2] * S.m[0][2] + S.m[1][2] * S.m[1][2];
  const double a = S.m[0][0] - q, b = S.m[1][1] - q, c = S.m[2][2] - q;
  const double p = std::sqrt((a * a + b * b + c * c + 2 * off) / 6);
  if (p == 0) {
    l[0] = l[1] = l[2] = q;
  } else {
    // B = (S - q I) / p; det(B) / 2 = cos(3 phi).
    const double ba = a / p, bb = b / p, bc = c / p, b01 = S.m[0][1] / p, b02 = S.m[0][2] / p, b12 = S.m[1][2] / p;
    const double det_b = ba * (bb * bc - b12 * b12) - b01 * (b01 * bc - b12 * b02) + b02 * (b01 * b12 - bb * b02);
    const double r = std::fmin(1.0, std::fmax(-1.0, 0.5 * det_b));
    const double phi = std::acos(r) / 3, third = 2.0943951023931954923;  // 2 pi / 3
    l[0] = q + 2 * p * std::cos(phi);
    l[2] = q + 2 * p * std::cos(phi + third);
    l[1] = 3 * q - l[0] - l[2];
    const double largest = std::fmax(std::fabs(l[0]), std::fmax(std::fabs(l[1]), std::fabs(l[2])));
    if (std::fmin(std::fabs(l[0] - l[1]), std::fabs(l[1] - l[2])) < kDirectGap * largest)
      stress_measures_detail::jacobi_eigenvalues(S, l);
  }
  // Decreasing (std::swap is not a device function in C++17).
  double x = l[0], y = l[1], z = l[2], t;
  if (x < y) t = x, x = y, y = t;
  if (y < z) t = y, y = z, z = t;
  if (x < y) t = x, x = y, y = t;
  return {x, y, z};
}

}  // namespace fascia
