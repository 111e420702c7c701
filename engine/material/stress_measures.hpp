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
#pragma once

#include "material/material.hpp"

#include <array>

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
StressMeasures stress_measures(const Material& material, const Mat3& F);

// sqrt(3/2 dev(A) : dev(A)) for a symmetric A (Pa for a stress).
double von_mises(const Mat3& A);

// Eigenvalues of the symmetric part of A, in decreasing order.
std::array<double, 3> principal_values(const Mat3& A);

}  // namespace fascia
