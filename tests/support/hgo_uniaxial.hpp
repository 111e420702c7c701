// Closed form of the fibre-reinforced law (engine/material/hgo.hpp) in uniaxial tension, for the
// material tests and the static bar: principal stresses at a diagonal F with the fibres in the
// e1-e2 plane, and the lateral stretches of free lateral faces.
#pragma once

#include "material/material.hpp"

#include <cmath>

namespace fascia::test {

// Principal stresses of the law at F = diag(l1, l2, l3) with the fibres in the e1-e2 plane,
// a_k = (cos gamma, +-sin gamma, 0) (one family: a_0 = e1, gamma = 0), as tau_i = P_ii l_i (Pa).
// From hgo.hpp and isochoric.hpp, with G = diag(1 / l_i), I1 = sum l_i^2, J = l1 l2 l3,
// j = J^{-2/3}, q = H_k : C = kappa I1 + (1 - 3 kappa) I4, I4 = l1^2 cos^2 gamma + l2^2 sin^2 gamma
// (the same for both families), (H_k)_11 = kappa + (1 - 3 kappa) cos^2 gamma,
// (H_k)_22 = kappa + (1 - 3 kappa) sin^2 gamma, (H_k)_33 = kappa, g = k1 <E> exp(k2 <E>^2) and
// n the number of families:
//   coupled, E = q - 1:       P = mu (F - G) + lambda ln J G + sum_k 2 g F H_k
//     tau_i = mu (l_i^2 - 1) + lambda ln J + 2 n g l_i^2 (H)_ii
//   uncoupled, E = j q - 1:   P = mu/2 j (2 F - 2/3 I1 G) + K ln J G + sum_k g j (2 F H_k - 2/3 q G)
//     tau_i = mu j (l_i^2 - I1/3) + K ln J + 2 n g j (l_i^2 (H)_ii - q/3),   K = lambda + 2 mu / 3
// The off-diagonal entries of F H_k are l_i (H_k)_ij: the two families' are opposite and cancel,
// so P is diagonal.
struct Principal {
  double tau[3];
  double e;  // the families' fibre strain E
};
inline Principal principal_stresses(const Material& m, double gamma, const double l[3]) {
  const double mu = m.mu, lam = m.lambda, K = lam + 2 * mu / 3, k1 = m.fibres.k1, k2 = m.fibres.k2;
  const double kappa = m.fibres.dispersion, n = m.fibres.families;
  const double c2 = std::cos(gamma) * std::cos(gamma), s2 = std::sin(gamma) * std::sin(gamma);
  const double I1 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2], J = l[0] * l[1] * l[2], ln_j = std::log(J);
  const double I4 = l[0] * l[0] * c2 + l[1] * l[1] * s2, q = kappa * I1 + (1 - 3 * kappa) * I4;
  const double Hd[3] = {kappa + (1 - 3 * kappa) * c2, kappa + (1 - 3 * kappa) * s2, kappa};
  const bool uncoupled = m.formulation == HgoFormulation::uncoupled;
  const double j = uncoupled ? std::pow(J, -2.0 / 3) : 1.0;
  Principal out{};
  out.e = j * q - 1;
  const double g = out.e > 0 ? k1 * out.e * std::exp(k2 * out.e * out.e) : 0.0;
  for (int i = 0; i < 3; ++i)
    out.tau[i] = uncoupled ? mu * j * (l[i] * l[i] - I1 / 3) + K * ln_j + 2 * n * g * j * (l[i] * l[i] * Hd[i] - q / 3)
                           : mu * (l[i] * l[i] - 1) + lam * ln_j + 2 * n * g * l[i] * l[i] * Hd[i];
  return out;
}

// The lateral stretches of uniaxial tension: l[axis] = s is given, the other two solve
// tau_a = tau_b = 0 (free lateral faces), by Newton's method from 1 / sqrt(s) with a
// central-difference Jacobian (h = 1e-7, relative error ~1e-7: each step gains about seven
// digits), until a step no longer changes them (the rounding of tau).
inline void solve_lateral(const Material& m, double gamma, int axis, double s, double l[3]) {
  const int a = (axis + 1) % 3, b = (axis + 2) % 3;
  l[axis] = s;
  l[a] = l[b] = 1 / std::sqrt(s);
  const auto residual = [&](double x, double y, double r[2]) {
    double t[3];
    t[axis] = s;
    t[a] = x;
    t[b] = y;
    const Principal p = principal_stresses(m, gamma, t);
    r[0] = p.tau[a];
    r[1] = p.tau[b];
  };
  const double h = 1e-7;
  for (int it = 0; it < 100; ++it) {
    double r[2], rxp[2], rxm[2], ryp[2], rym[2];
    residual(l[a], l[b], r);
    residual(l[a] + h, l[b], rxp);
    residual(l[a] - h, l[b], rxm);
    residual(l[a], l[b] + h, ryp);
    residual(l[a], l[b] - h, rym);
    const double J00 = (rxp[0] - rxm[0]) / (2 * h), J01 = (ryp[0] - rym[0]) / (2 * h);
    const double J10 = (rxp[1] - rxm[1]) / (2 * h), J11 = (ryp[1] - rym[1]) / (2 * h);
    const double d = J00 * J11 - J01 * J10;
    const double na = l[a] - (J11 * r[0] - J01 * r[1]) / d, nb = l[b] - (J00 * r[1] - J10 * r[0]) / d;
    if (na == l[a] && nb == l[b]) break;
    l[a] = na;
    l[b] = nb;
  }
}

}  // namespace fascia::test
