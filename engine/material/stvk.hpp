// Saint Venant-Kirchhoff hyperelasticity (paper eq. 5 and 19).
//   E = 1/2 (F^T F - I)                      Green-Lagrange strain (eq. 5)
//   psi = lambda/2 tr(E)^2 + mu tr(E^2)        energy density, J/m^3
//   S = lambda tr(E) I + 2 mu E                second Piola-Kirchhoff stress (eq. 19), Pa
//   P = F S,  dP = dF S + F (lambda tr(dE) I + 2 mu dE),  dE = sym(F^T dF)
// In Voigt form {S} = C {E} with {E} = (E11, E22, E33, 2E23, 2E13, 2E12): the factor 2 sits on
// the shear strains (eq. 16). StVK softens in compression and can invert; see neo_hookean.hpp.
#pragma once

#include "core/small_math.hpp"

namespace fascia {

template <class T>
FASCIA_HD Mat3T<T> green_lagrange_strain(const Mat3T<T>& F) {
  Mat3T<T> E = transpose(F) * F;
  E.m[0][0] -= 1;
  E.m[1][1] -= 1;
  E.m[2][2] -= 1;
  return T(0.5) * E;
}

FASCIA_HD double stvk_energy(double lambda, double mu, const Mat3& F) {
  const Mat3 E = green_lagrange_strain(F);
  const double tr = trace(E);
  return 0.5 * lambda * tr * tr + mu * ddot(E, E);
}

template <class T>
FASCIA_HD Mat3T<T> stvk_stress_from_strain(Scalar<T> lambda, Scalar<T> mu, const Mat3T<T>& E) {
  Mat3T<T> S = (2 * mu) * E;
  const T lt = lambda * trace(E);
  S.m[0][0] += lt;
  S.m[1][1] += lt;
  S.m[2][2] += lt;
  return S;
}

template <class T>
FASCIA_HD Mat3T<T> stvk_second_piola(Scalar<T> lambda, Scalar<T> mu, const Mat3T<T>& F) {
  return stvk_stress_from_strain<T>(lambda, mu, green_lagrange_strain(F));
}

// dP for the stress S = stvk_second_piola(F).
template <class T>
FASCIA_HD Mat3T<T> stvk_pk1_differential(Scalar<T> lambda, Scalar<T> mu, const Mat3T<T>& F, const Mat3T<T>& S,
                                         const Mat3T<T>& dF) {
  const Mat3T<T> dE = symmetric_part(transpose(F) * dF);
  return dF * S + F * stvk_stress_from_strain<T>(lambda, mu, dE);
}

}  // namespace fascia
