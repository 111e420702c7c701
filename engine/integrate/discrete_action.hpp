// One frame's terms of the variational step's discrete action (variational_step.hpp, eq. (1)-(3)),
// written once for the CPU step (variational_step.cpp) and the CUDA one (kernels/
// device_variational.cu). A frame moves from (x0, q0) at t_k to (x1, q1) at t_{k+1} over h (s);
// m is its mass (kg), J its body inertia about its origin (kg m^2). With `locked` (Model::
// rotations_locked) the rotational terms vanish: those DOFs are fixed.
#pragma once

#include "core/rotation.hpp"
#include "core/small_math.hpp"
#include "mechanics/frame_inertia.hpp"

#include <cmath>

namespace fascia {

// J_l(phi), the left Jacobian of SO(3) (Barfoot, State Estimation, eq. 7.77a):
// exp([phi + e]x) = exp([J_l(phi) e]x) exp([phi]x) + O(e^2).
FASCIA_HD Mat3 left_jacobian(const Vec3& phi) {
  const double t = norm(phi);
  // Coefficients (1 - cos t)/t^2 and (t - sin t)/t^3; their Taylor series below t = 1e-3, where
  // the closed forms lose about 6 and 9 digits to cancellation.
  const double a = t < 1e-3 ? 0.5 - t * t / 24.0 : (1 - std::cos(t)) / (t * t);
  const double b = t < 1e-3 ? 1.0 / 6.0 - t * t / 120.0 : (t - std::sin(t)) / (t * t * t);
  const Mat3 K = skew(phi);
  return identity3() + a * K + b * (K * K);
}

// Jd = tr(J)/2 I - J, the non-standard inertia (Lee et al. eq. (6)).
FASCIA_HD Mat3 nonstandard_inertia(const Mat3& J) { return 0.5 * trace(J) * identity3() - J; }

// psi = log(R1 R0^T), world axes (rad).
FASCIA_HD Vec3 relative_rotation(const Quat& q0, const Quat& q1) { return quat_log(q1 * conjugate(q0)); }

// The frame's kinetic part of (1), J s: m |x1 - x0|^2 / (2h) + tr((I - R0^T R1) Jd) / h.
FASCIA_HD double kinetic_action(double m, const Mat3& J, const Vec3& x0, const Quat& q0, const Vec3& x1,
                                const Quat& q1, double h, bool locked) {
  const Vec3 dx = x1 - x0;
  double s = 0.5 * m * dot(dx, dx) / h;
  if (locked) return s;
  const Mat3 F = transpose(rotation_matrix(q0)) * rotation_matrix(q1);
  return s + trace((identity3() - F) * nonstandard_inertia(J)) / h;
}

// The geodesic midpoint: x = (x0 + x1) / 2, q = exp(psi / 2) q0 (q1 where locked).
FASCIA_HD void midpoint_frame(const Vec3& x0, const Quat& q0, const Vec3& x1, const Quat& q1, bool locked, Vec3& x,
                              Quat& q) {
  x = 0.5 * (x0 + x1);
  q = locked ? q1 : apply_increment(q0, 0.5 * relative_rotation(q0, q1));
}

// Kinetic momenta kappa (world axes): translation m (x1 - x0) / h (N s), rotation (2)
// R0 vee(C - C^T) / h with C = R0^T R1 Jd (N m s; zero where locked).
FASCIA_HD void kinetic_momentum(double m, const Mat3& J, const Vec3& x0, const Quat& q0, const Vec3& x1,
                                const Quat& q1, double h, bool locked, Vec3& px, Vec3& pr) {
  px = (m / h) * (x1 - x0);
  pr = Vec3{0, 0, 0};
  if (locked) return;
  const Mat3 R0 = rotation_matrix(q0);
  const Mat3 C = transpose(R0) * rotation_matrix(q1) * nonstandard_inertia(J);
  pr = (1 / h) * (R0 * Vec3{C.m[2][1] - C.m[1][2], C.m[0][2] - C.m[2][0], C.m[1][0] - C.m[0][1]});
}

// A^T tau and B^T tau of (3) for the rotational gradient tau at the midpoint (the translational
// parts are g / 2 each); zero where locked.
FASCIA_HD void midpoint_transposes(const Quat& q0, const Quat& q1, bool locked, const Vec3& tau, Vec3& at_tau,
                                   Vec3& bt_tau) {
  if (locked) {
    at_tau = bt_tau = Vec3{0, 0, 0};
    return;
  }
  const Vec3 psi = relative_rotation(q0, q1);
  const Mat3 Jh = left_jacobian(0.5 * psi);
  const Mat3 A = 0.5 * (Jh * inverse_left_jacobian(psi));
  const Mat3 B = rotation_matrix(quat_exp(0.5 * psi)) - 0.5 * (Jh * inverse_left_jacobian(-1.0 * psi));
  at_tau = transpose(A) * tau;
  bt_tau = transpose(B) * tau;
}

// The frame's block [36] (row-major 6x6) of c M_kin: c m I3 on the translations and, unless
// locked, c R0 sym(tr(C) I - C) R0^T on the rotations (C as in kinetic_momentum, c = 4 / h^2 in
// the iteration matrix 4 H).
FASCIA_HD void kinetic_block(double m, const Mat3& J, const Quat& q0, const Quat& q1, double c, bool locked,
                             double* b) {
  for (int k = 0; k < 36; ++k) b[k] = 0;
  for (int k = 0; k < 3; ++k) b[7 * k] = c * m;
  if (locked) return;
  const Mat3 R0 = rotation_matrix(q0);
  const Mat3 C = transpose(R0) * rotation_matrix(q1) * nonstandard_inertia(J);
  const Mat3 Q = R0 * symmetric_part(trace(C) * identity3() - C) * transpose(R0);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) b[6 * (3 + r) + 3 + col] = c * Q.m[r][col];
}

}  // namespace fascia
