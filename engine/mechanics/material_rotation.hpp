// A frame's material rotation, which the preconditioner of a kept factorisation follows
// (solve/factorised_solve.hpp): the rotation of the polar decomposition (core/rotation.hpp,
// polar_rotation) of the weighted sum of the deformation gradients of the samples the frame
// reaches,
//   A_i = sum_s w_is v_s F_s      (w_is of eq. 4, v_s the sample's volume; A_i in m^3),
// started from the frame's own orientation q_i (rest orientations are identity, so q_i is the
// frame's turn since rest). A frame that no sample reaches (a rigid body's, a shell's) has A_i = 0
// and keeps q_i. A rigid turn R of the whole model maps F_s to R F_s and q_i to R q_i, so every
// frame's material rotation turns by R.
#pragma once

#include "core/rotation.hpp"

namespace fascia {

// A += wv F, F [9] row-major (a sample's deformation gradient, stored as T), wv = w_is v_s.
template <class T>
FASCIA_HD void add_material_share(Mat3& A, double wv, const T* F) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) A.m[r][c] += wv * static_cast<double>(F[3 * r + c]);
}

// The material rotation of a frame with sum A (above) and orientation q.
FASCIA_HD Quat material_rotation(const Mat3& A, const Quat& q) { return polar_rotation(A, q); }

}  // namespace fascia
