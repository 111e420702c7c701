// Per-sample and per-pair mechanics of the frame method (paper §2.2), written once for the CPU
// reference and the CUDA kernels.
//
// Notation (DESIGN.md): frame i has position x_i and rotation R_i; a sample-frame pair p = (s, i)
// carries the weight w, its rest-space gradient g = grad w (1/m) and the rest offset l (eq. 2).
// a = R_i l is the offset rotated into the deformed configuration. A frame increment is
// d = [dx, dr] (m, rad), with dr in world axes: R_i <- exp([dr]x) R_i.
#pragma once

#include "core/small_math.hpp"

namespace fascia {

// Read-only view of the neighbour table (model.hpp) through raw pointers (host or device).
struct PairTableView {
  const int* offsets;             // [S+1]
  const int* frames;              // [P]
  const double* weights;          // [P]
  const double* weight_gradients; // [P][3]
  const double* rest_offsets;     // [P][3]
};

// Deformation gradient of sample s, eq. (8) with rest orientations R_i = I:
//   F = sum_i (x_i + R_i l_i) g_i^T + w_i R_i.
// x: [N][3] frame positions, R: [N][9] row-major rotations.
FASCIA_HD Mat3 sample_deformation_gradient(const PairTableView& t, int s, const double* x, const double* R) {
  Mat3 F = zero3();
  for (int p = t.offsets[s]; p < t.offsets[s + 1]; ++p) {
    const int i = t.frames[p];
    const Mat3 Ri = load_mat3(R + 9 * i);
    const Vec3 y = load3(x + 3 * i) + Ri * load3(t.rest_offsets + 3 * p);
    F += outer(y, load3(t.weight_gradients + 3 * p)) + t.weights[p] * Ri;
  }
  return F;
}

// Sample position, eq. (3): p = sum_i w_i (x_i + R_i l_i).
FASCIA_HD Vec3 sample_position(const PairTableView& t, int s, const double* x, const double* R) {
  Vec3 pos{0, 0, 0};
  for (int p = t.offsets[s]; p < t.offsets[s + 1]; ++p) {
    const int i = t.frames[p];
    pos += t.weights[p] * (load3(x + 3 * i) + load_mat3(R + 9 * i) * load3(t.rest_offsets + 3 * p));
  }
  return pos;
}

// Differential of F along a frame increment of one pair (eq. 10, 11: the 9x6 block B times d):
//   dF_p = (dx + dr x a) g^T + w [dr]x R.
template <class T>
FASCIA_HD Mat3T<T> pair_deformation_differential(const Vec3T<T>& dx, const Vec3T<T>& dr, const Vec3T<T>& a,
                                                 const Vec3T<T>& g, Scalar<T> w, const Mat3T<T>& R) {
  return outer(dx + cross(dr, a), g) + w * (skew(dr) * R);
}

// The pair's share of v P : dF seen as a linear form in d = [dx, dr] (the transpose of the
// pair's B block applied to P, eq. 17-18 written with P = F S):
//   out_x = v P g,   out_r = v (a x (P g) + w axial(R P^T)).
// With P the stress this is the energy gradient (minus the internal force, eq. 18); with P = dP
// it is the pair's share of the tangent product (eq. 21-24).
template <class T>
FASCIA_HD void pair_virtual_work(const Mat3T<T>& P, const Vec3T<T>& a, const Vec3T<T>& g, Scalar<T> w,
                                 const Mat3T<T>& R, Scalar<T> v, T* out) {
  const Vec3T<T> u = P * g;
  const Vec3T<T> t = cross(a, u) + w * axial(R * transpose(P));
  out[0] = v * u.x;
  out[1] = v * u.y;
  out[2] = v * u.z;
  out[3] = v * t.x;
  out[4] = v * t.y;
  out[5] = v * t.z;
}

// The pair's lever M = a g^T + w R, which folds the rotational columns of the pair's B block into
// one 3x3 matrix: dF_p = dx g^T + [dr]x M (the same dF as pair_deformation_differential, since
// (dr x a) g^T = [dr]x a g^T), and its transpose B^T P = [P g, axial(M P^T)] (pair_virtual_work
// with v = 1, since axial(a (P g)^T) = a x (P g)). Precomputed once per state, it turns every
// tangent product's pair work into 27 + 27 multiply-adds.
template <class T>
FASCIA_HD Mat3T<T> pair_lever(const Vec3T<T>& a, const Vec3T<T>& g, Scalar<T> w, const Mat3T<T>& R) {
  return outer(a, g) + w * R;
}

template <class T>
FASCIA_HD Mat3T<T> pair_lever_differential(const Vec3T<T>& dx, const Vec3T<T>& dr, const Vec3T<T>& g,
                                           const Mat3T<T>& M) {
  return outer(dx, g) + skew_times(dr, M);
}

// A pair's 6 generalised values [u (force part), t (torque part)] into out.
template <class T>
FASCIA_HD void store_pair_values(const Vec3T<T>& u, const Vec3T<T>& t, T* out) {
  out[0] = u.x;
  out[1] = u.y;
  out[2] = u.z;
  out[3] = t.x;
  out[4] = t.y;
  out[5] = t.z;
}

// out = [P g, axial(M P^T)]: B_p^T applied to P, 6 values.
template <class T>
FASCIA_HD void pair_lever_virtual_work(const Mat3T<T>& P, const Vec3T<T>& g, const Mat3T<T>& M, T* out) {
  store_pair_values(P * g, axial_times_transpose(M, P), out);
}

// The pair's share of the rotational geometric stiffness that comes from the second derivative
// of exp([dr]x) R (the term v P : F''[d, e] of the symmetric Hessian, DESIGN.md; it completes
// eq. 25-28). Only rotation-rotation of the same frame, a symmetric 3x3 block:
//   v [ w (sym(A) - tr(A) I) + 1/2 (u a^T + a u^T) - (u . a) I ],  A = R P^T, u = P g.
FASCIA_HD Mat3 pair_rotational_geometric_block(const Mat3& P, const Vec3& a, const Vec3& g, double w, const Mat3& R,
                                               double v) {
  const Mat3 A = R * transpose(P);
  const Vec3 u = P * g;
  Mat3 K = w * symmetric_part(A) + 0.5 * (outer(u, a) + outer(a, u));
  const double diag = w * trace(A) + dot(u, a);
  K.m[0][0] -= diag;
  K.m[1][1] -= diag;
  K.m[2][2] -= diag;
  return v * K;
}

// The same block for a constant force b (N) applied at the sample through eq. (3), potential
// -b . p_s: gradient [-w b, -w (a x b)], rotational block -w [1/2 (b a^T + a b^T) - (b . a) I].
FASCIA_HD Mat3 pair_body_force_block(const Vec3& b, const Vec3& a, double w) {
  Mat3 K = (-0.5 * w) * (outer(b, a) + outer(a, b));
  const double diag = w * dot(b, a);
  K.m[0][0] += diag;
  K.m[1][1] += diag;
  K.m[2][2] += diag;
  return K;
}

}  // namespace fascia
