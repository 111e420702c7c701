// Compressible neo-Hookean hyperelasticity (Bonet & Wood, Nonlinear Continuum Mechanics, §6.4.3):
//   psi = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2,   J = det F > 0
//   P   = mu (F - F^{-T}) + lambda ln J F^{-T}
//   dP  = mu dF + (mu - lambda ln J) F^{-T} dF^T F^{-T} + lambda tr(F^{-1} dF) F^{-T}
// Unlike StVK it resists inversion: psi -> +inf as J -> 0+. For J <= 0 the energy is +inf and
// the stress is not defined; the solvers' line searches reject such states.
#pragma once

#include "core/small_math.hpp"

namespace fascia {

FASCIA_HD double neo_hookean_energy(double lambda, double mu, const Mat3& F) {
  const double J = det(F);
  if (!(J > 0)) return HUGE_VAL;
  const double ln_j = std::log(J);
  return 0.5 * mu * (ddot(F, F) - 3) - mu * ln_j + 0.5 * lambda * ln_j * ln_j;
}

// Returns P and fills f_inv_t = F^{-T} and c = mu - lambda ln J for the differential.
// @pre det F > 0.
FASCIA_HD Mat3 neo_hookean_first_piola(double lambda, double mu, const Mat3& F, Mat3& f_inv_t, double& c) {
  const double J = det(F);
  const double ln_j = std::log(J > 0 ? J : 1e-300);
  f_inv_t = inverse_transpose(F);
  c = mu - lambda * ln_j;
  return mu * F + (lambda * ln_j - mu) * f_inv_t;
}

template <class T>
FASCIA_HD Mat3T<T> neo_hookean_pk1_differential(Scalar<T> lambda, Scalar<T> mu, const Mat3T<T>& f_inv_t, Scalar<T> c,
                                                const Mat3T<T>& dF) {
  // tr(F^{-1} dF) = F^{-T} : dF
  const T tr = ddot(f_inv_t, dF);
  return mu * dF + c * (f_inv_t * transpose(dF) * f_inv_t) + (lambda * tr) * f_inv_t;
}

}  // namespace fascia
