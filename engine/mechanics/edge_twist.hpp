// Energy, gradient and Hessian of one edge twist term of the rotation stabilisation
// (mechanics/rotation_stabilisation.hpp), written once for the CPU driver
// (mechanics/rotation_stabilisation.cpp) and the CUDA driver (kernels/device_stabilisation.cu):
// FASCIA_HD functions on fixed-size arrays, no allocation.
//
// E = k/8 tau^2, tau = e . axial(R_i^T R_j), over the edge's rotation increments
// (dr_i, dr_j) [6] (rad): with C = R_i^T R_j, dC[d] = R_i^T [d_j - d_i]x R_j and
// d2C[d, f] = R_i^T (sym([d_i]x [f_i]x) - [d_i]x [f_j]x - [f_i]x [d_j]x + sym([d_j]x [f_j]x)) R_j
// (rotation_stabilisation.hpp), so dE = k/4 tau dtau and d2E = k/4 (dtau dtau^T + tau d2tau),
// exact at theta = 0. tests/mechanics/test_rotation_stabilisation.cpp checks them against central
// differences of the energy.
#pragma once

#include "core/small_math.hpp"

namespace fascia {

// Rotational degrees of freedom of one edge: (dr_i, dr_j).
constexpr int kEdgeTwistDofs = 6;

// One edge: its frames i, j, its rest unit direction e_ij and its stiffness k (J).
struct EdgeTwist {
  int nodes[2];
  Vec3 direction;
  double stiffness;
};

struct EdgeTwistTerm {
  double energy;                                    // J
  double gradient[kEdgeTwistDofs];                  // dE / d(dr_i, dr_j), J/rad
  double hessian[kEdgeTwistDofs][kEdgeTwistDofs];   // symmetric, J/rad^2
};

// [v]x for the unit vector of DOF a (0..5) where it belongs to node `which` (0: i, 1: j), else 0.
FASCIA_HD Mat3 edge_twist_unit_skew(int a, int which) {
  Vec3 v{0, 0, 0};
  if (a / 3 == which) v = Vec3{a % 3 == 0 ? 1.0 : 0.0, a % 3 == 1 ? 1.0 : 0.0, a % 3 == 2 ? 1.0 : 0.0};
  return skew(v);
}

// tau = e . axial(R_i^T R_j).
FASCIA_HD double edge_twist(const EdgeTwist& edge, const Mat3& Ri, const Mat3& Rj) {
  return dot(edge.direction, axial(transpose(Ri) * Rj));
}

FASCIA_HD double edge_twist_energy(const EdgeTwist& edge, const Mat3& Ri, const Mat3& Rj) {
  const double tau = edge_twist(edge, Ri, Rj);
  return 0.125 * edge.stiffness * tau * tau;
}

// The energy and gradient, and the Hessian where `hessian` is set (else t.hessian is left as is).
FASCIA_HD EdgeTwistTerm edge_twist_term(const EdgeTwist& edge, const Mat3& Ri, const Mat3& Rj, bool hessian) {
  const Mat3 Rit = transpose(Ri);
  const Vec3& e = edge.direction;
  const double k = edge.stiffness;
  const double tau = dot(e, axial(Rit * Rj));
  EdgeTwistTerm t{};
  t.energy = 0.125 * k * tau * tau;
  double dtau[kEdgeTwistDofs];
  for (int a = 0; a < kEdgeTwistDofs; ++a)
    dtau[a] = dot(e, axial(Rit * (edge_twist_unit_skew(a, 1) - edge_twist_unit_skew(a, 0)) * Rj));
  for (int a = 0; a < kEdgeTwistDofs; ++a) t.gradient[a] = 0.25 * k * tau * dtau[a];
  if (!hessian) return t;
  for (int a = 0; a < kEdgeTwistDofs; ++a)
    for (int b = a; b < kEdgeTwistDofs; ++b) {
      const Mat3 ai = edge_twist_unit_skew(a, 0), aj = edge_twist_unit_skew(a, 1);
      const Mat3 bi = edge_twist_unit_skew(b, 0), bj = edge_twist_unit_skew(b, 1);
      const Mat3 second = 0.5 * (ai * bi + bi * ai) - ai * bj - bi * aj + 0.5 * (aj * bj + bj * aj);
      const double d2tau = dot(e, axial(Rit * second * Rj));
      t.hessian[a][b] = t.hessian[b][a] = 0.25 * k * (dtau[a] * dtau[b] + tau * d2tau);
    }
  return t;
}

}  // namespace fascia
