// Inertia and Rayleigh damping of the backward-Euler step, per frame (DESIGN.md;
// integrate/step_potential.hpp), written once for the CPU reference and the CUDA driver
// (kernels/device_potential.cu):
//   Phi_i = 1/(2h^2) |Delta_i - h v_i|^2_M + 1/(2h) Delta_i^T (alpha M_i) Delta_i
//           + beta/(2h) Delta_i^T (K_n Delta)_i
// with Delta_i = [x_i - x_n,i, phi_i = log(R_i R_n,i^T)], M_i = diag(m_i I3, I_i), I_i = R_n I_0 R_n^T
// the world inertia at the step start (gyroscopic terms neglected), K_n the elastic tangent at the
// step start. The rotational gradient carries J_l^{-T}(phi) (d log(exp(theta) exp(phi)) / d theta
// = J_l^{-1}(phi)); the Hessian uses J_l ~ I (exact for translations and at phi = 0).
#pragma once

#include "core/rotation.hpp"
#include "core/small_math.hpp"

#include <cmath>

namespace fascia {

// J_l^{-1}(phi), the inverse left Jacobian of SO(3) (Barfoot, State Estimation, eq. 7.77a).
FASCIA_HD Mat3 inverse_left_jacobian(const Vec3& phi) {
  const double t = norm(phi);
  // Coefficient of [phi]x^2: 1/t^2 - (1 + cos t) / (2 t sin t); its Taylor series 1/12 + t^2/720
  // below t = 1e-3, where the closed form loses about 10 digits to cancellation.
  const double c = t < 1e-3 ? 1.0 / 12.0 + t * t / 720.0 : 1.0 / (t * t) - (1 + std::cos(t)) / (2 * t * std::sin(t));
  const Mat3 K = skew(phi);
  return identity3() - 0.5 * K + c * (K * K);
}

// Delta_i of frame i: [x - x_n, log(q q_n^*)] (m, rad).
struct FrameIncrement {
  Vec3 dx, phi;
};
FASCIA_HD FrameIncrement frame_increment(const Vec3& x, const Quat& q, const Vec3& x_start, const Quat& q_start) {
  return FrameIncrement{x - x_start, quat_log(q * conjugate(q_start))};
}

// Phi_i (J) and its gradient w.r.t. frame i's left increment (gx in N, gr in N m; gr already
// multiplied by J_l^{-T}(phi)). kd = (K_n Delta)_i, used when beta > 0.
struct FrameInertiaTerm {
  double value;
  Vec3 gx, gr;
};
FASCIA_HD FrameInertiaTerm frame_inertia_term(double m, const Mat3& I, const FrameIncrement& delta, const Vec3& v,
                                              const Vec3& w, double h, double alpha, double beta, const Vec3& kdx,
                                              const Vec3& kdr) {
  const Vec3 ex = delta.dx - h * v, er = delta.phi - h * w;
  FrameInertiaTerm t;
  t.value = 0.5 / (h * h) * (m * dot(ex, ex) + dot(er, I * er)) +
            0.5 * alpha / h * (m * dot(delta.dx, delta.dx) + dot(delta.phi, I * delta.phi));
  Vec3 gx = (1 / (h * h)) * (m * ex) + (alpha / h) * (m * delta.dx);
  Vec3 gr = (1 / (h * h)) * (I * er) + (alpha / h) * (I * delta.phi);
  if (beta > 0) {
    t.value += 0.5 * beta / h * (dot(delta.dx, kdx) + dot(delta.phi, kdr));
    gx += (beta / h) * kdx;
    gr += (beta / h) * kdr;
  }
  t.gx = gx;
  t.gr = transpose(inverse_left_jacobian(delta.phi)) * gr;
  return t;
}

// The mass-like diagonal of the Hessian, (1 + alpha h)/h^2 [m I3, I]: the translational scalar
// and the rotational 3x3 block.
FASCIA_HD double frame_inertia_scale(double h, double alpha) { return (1 + alpha * h) / (h * h); }

}  // namespace fascia
