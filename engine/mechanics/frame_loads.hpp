// The external loads of mechanics/external_loads.hpp summed per frame, written once for every
// backend: every load is a constant force b_k applied at a point x_i + R_i l_k that moves with a
// frame i (gravity on the samples through eq. (3), point masses, point forces, material-point
// forces), so its potential is -b_k . (x_i + R_i l_k) and the frame's sum is
//   V_i = -s (f_i . x_i + tr(R_i C_i)),   f_i = sum_k b_k (N),   C_i = sum_k l_k b_k^T (N m),
// at load factor s (ExternalLoads::scale). With M_i = R_i C_i = sum_k a_k b_k^T (a_k = R_i l_k):
//   dV/d(theta_i) = -s [f_i, axial(M_i)]                        (axial(M) = sum_k a_k x b_k)
//   d2V/d(dr_i)^2 = s (tr(M_i) I - (M_i + M_i^T) / 2)           (mechanics/frame_sample.hpp,
//                                                                pair_body_force_block, summed)
// The translational Hessian is zero (constant forces).
#pragma once

#include "core/small_math.hpp"
#include "mechanics/external_loads.hpp"
#include "model/model.hpp"
#include "model/state.hpp"

#include <vector>

namespace fascia {

// The loads' moments f and C of every frame, summed once from the model and the loads (which must
// not change after; their load factor ExternalLoads::scale is given to each evaluation instead),
// and V, dV/d(theta) and V's rotational Hessian blocks from them, O(N) per evaluation.
class FrameLoads {
 public:
  FrameLoads(const Model& model, const ExternalLoads& loads);

  const std::vector<double>& forces() const { return m_f; }   // f [N][3] (N) at load factor 1
  const std::vector<double>& moments() const { return m_C; }  // C [N][9] row-major (N m) at load factor 1

  // V = sum_i V_i (J) at load factor s.
  double value(const State& state, double s) const;
  // Adds dV/d(theta) at load factor s to gradient [N][6].
  void add_gradient(const State& state, double s, double* gradient) const;
  // Adds the rotational Hessian blocks of V at load factor s to blocks [N][9].
  void add_rotational_blocks(const State& state, double s, double* blocks) const;
  // |f| summed per frame at load factor s (N): the external force scale of Newton's tolerance.
  double force_norm(double s) const;

 private:
  std::vector<double> m_f, m_C;
};

// V_i (J) of frame i at load factor s.
FASCIA_HD double frame_load_value(const Vec3& f, const Mat3& C, const Vec3& x, const Mat3& R, double s) {
  return -s * (dot(f, x) + trace(R * C));
}

// dV/d(theta_i): translation (N) and world-axis rotation (N m).
FASCIA_HD void frame_load_gradient(const Vec3& f, const Mat3& C, const Mat3& R, double s, Vec3& gx, Vec3& gr) {
  gx = (-s) * f;
  gr = (-s) * axial(R * C);
}

// The rotational Hessian block of V_i (N m).
FASCIA_HD Mat3 frame_load_rotational_block(const Mat3& C, const Mat3& R, double s) {
  const Mat3 M = R * C;
  Mat3 K = (-0.5 * s) * (M + transpose(M));
  const double t = s * trace(M);
  for (int k = 0; k < 3; ++k) K.m[k][k] += t;
  return K;
}

}  // namespace fascia
