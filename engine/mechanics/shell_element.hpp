// Energy, gradient and Hessian of one corotational shell triangle (the element of mechanics/shell.hpp),
// in closed form, written once for the CPU driver (mechanics/shell.cpp) and the CUDA driver: FASCIA_HD
// function templates on the scalar type T, on fixed-size arrays, no allocation. T = double on the
// device; the CPU evaluates four triangles at once with T = DoubleLanes (core/double_lanes.hpp).
//
// Unknowns of a triangle: theta = [dx_0, dr_0, dx_1, dr_1, dx_2, dr_2] (18, m and rad), the increments
// x_i + dx_i, R_i <- exp([dr_i]x) R_i. The gradient and Hessian are those of theta -> W(q (+) theta) at
// theta = 0 (DESIGN.md), symmetric.
//
// Derivation. W = W_m(x) + Phi(s), where
//  * W_m is the membrane (shell.hpp): with f_c = e_c + U_c the deformed columns of F (c = 0, 1) and
//    S = 2 mu E + lambda* tr(E) I the plane-stress second Piola-Kirchhoff stress,
//      dW_m/dU_c = A t sum_d S_cd f_d,
//      d2W_m/dU_c dU_d = A t [S_cd I + C-terms]:  (0,0): (2mu+l) f0 f0^T + mu f1 f1^T,
//      (0,1): l f0 f1^T + mu f1 f0^T,  (1,1): (2mu+l) f1 f1^T + mu f0 f0^T  (l = lambda*),
//    and U_c = sum_i c_ci u_i with the constant weights c_ci of Dm^{-1} (dU_c/dx_i = c_ci I).
//  * s = (beta_0x, beta_0y, beta_1x, ..., psi_0, psi_1, psi_2) are 9 scalars, each of the form
//    s = e1 . c1 + e2 . c2 with c1, c2 linear in the directors d_ik = R_i E_k of one node i
//    (E_k the rest corotational axes): beta_ix: c1 = -d_i2; beta_iy: c2 = -d_i2;
//    psi_i: c1 = -d_i1 / 2, c2 = d_i0 / 2. Phi(s) = beta^T K_b beta / 2 + k_d / 2 sum psi_i^2 is
//    quadratic: Phi' = (K_b beta, k_d psi), Phi'' = diag(K_b, k_d I).
//    Hessian = G^T Phi'' G + sum_m Phi'_m Hess(s_m), with G = ds/dtheta (9 x 18); the second part is
//    the Hessian of e1 . C1 + e2 . C2 with the multipliers frozen, C_a = sum_m Phi'_m c_a,m.
//  * The corotational axes depend on a = x1 - x0 and b = x2 - x0 only: e1 = a/|a|,
//    e3 = n/|n| with n = a x b, e2 = e3 x e1. For a unit vector e = v/|v| and a constant c:
//      d(c . e)/dv = P c / |v|, P = I - e e^T,
//      d2(c . e)/dv2 = -[c e^T + e c^T + (c . e)(I - 3 e e^T)] / |v|^2,
//    n is bilinear in (a, b) (dn = -[b]x da + [a]x db; its second derivative puts -[g]x in the
//    (a, b) block of g . n), and c . e2 = e3 . (e1 x c) = e1 . (c x e3) adds the product term
//    de3 . (de1' x c) + de3' . (de1 x c).
//  * The directors turn with exp([dr]x) = I + [dr]x + [dr]x^2 / 2 + O(dr^3):
//      d(e . d_ik)/d dr_i = d_ik x e,  d2(e . d_ik)/d dr_i^2 = sym(e d_ik^T) - (e . d_ik) I,
//    and the mixed (x, dr_i) derivative of e . d is (de/dx)^T (-[d]x).
// All terms are exact at theta = 0 (no truncation); tests/mechanics/test_shell_element.cpp checks
// every entry against central differences of the element energy, tests/mechanics/test_shell.cpp
// the assembled field's forces, products, blocks and triplets. The CUDA driver is
// kernels/device_shell.cu.
#pragma once

#include "core/small_math.hpp"

namespace fascia {

// Degrees of freedom of one triangle: 3 nodes x [dx (3), dr (3)].
constexpr int kShellElementDofs = 18;

// Drilling penalty k_d = kShellDrillingFactor Y t A (mechanics/shell.hpp).
constexpr double kShellDrillingFactor = 1e-3;

// A triangle's rest data; T = double, or a lane type holding kDoubleLanes triangles (their nodes
// are then kept elsewhere).
template <class T>
struct ShellElementRestT {
  int nodes[3];
  T dm_inverse[2][2];  // Dm^{-1}, Dm = [P1 - P0, P2 - P0] in rest in-plane coordinates, 1/m
  T area;              // m^2
  Vec3T<T> axes[3];    // rest corotational frame e1, e2, e3 (world)
  Vec3T<T> rest[3];    // rest node positions, m
  T bending[6][6];     // DKT K_b on (beta_0x, beta_0y, beta_1x, ...), J
};
using ShellElementRest = ShellElementRestT<double>;

// Constants of one shell, shared by its triangles.
struct ShellModuli {
  double thickness;  // t, m
  double mu;         // plane-stress shear modulus Y / (2 (1 + nu)), Pa
  double lambda;     // plane-stress lambda* = Y nu / (1 - nu^2), Pa
  double drilling;   // k_d / A = kShellDrillingFactor Y t, Pa m
};

// Y in Pa, -1 < nu < 0.5, t in m.
FASCIA_HD ShellModuli make_shell_moduli(double young, double poisson, double thickness) {
  return ShellModuli{thickness, young / (2 * (1 + poisson)), young * poisson / (1 - poisson * poisson),
                     kShellDrillingFactor * young * thickness};
}

namespace shell_detail {

// Membrane strain and stress of one triangle (displacement form, shell.hpp).
template <class T>
struct Membrane {
  T energy;       // W_m, J
  Vec3T<T> f[2];  // deformed in-plane columns of F, f_c = E_c + U_c
  T S[2][2];      // plane-stress S, Pa
  T c[2][3];      // dU_c / du_i (the columns of Dm^{-1} with node 0 = -(node 1 + node 2)), 1/m
};

template <class T>
FASCIA_HD Membrane<T> membrane(const ShellElementRestT<T>& e, const ShellModuli& m, const Vec3T<T> x[3]) {
  Membrane<T> r;
  const Vec3T<T> u0 = x[0] - e.rest[0], u1 = x[1] - e.rest[1], u2 = x[2] - e.rest[2];
  const Vec3T<T> du1 = u1 - u0, du2 = u2 - u0;
  const Vec3T<T> U0 = e.dm_inverse[0][0] * du1 + e.dm_inverse[1][0] * du2;
  const Vec3T<T> U1 = e.dm_inverse[0][1] * du1 + e.dm_inverse[1][1] * du2;
  // E = sym(F0^T U) + U^T U / 2: no cancellation for small strains.
  const T e00 = dot(e.axes[0], U0) + 0.5 * dot(U0, U0);
  const T e11 = dot(e.axes[1], U1) + 0.5 * dot(U1, U1);
  const T e01 = 0.5 * (dot(e.axes[0], U1) + dot(e.axes[1], U0) + dot(U0, U1));
  const T tr = e00 + e11;
  r.energy = (e.area * m.thickness) * (m.mu * (e00 * e00 + 2.0 * (e01 * e01) + e11 * e11) + (0.5 * m.lambda) * (tr * tr));
  r.f[0] = e.axes[0] + U0;
  r.f[1] = e.axes[1] + U1;
  r.S[0][0] = 2 * m.mu * e00 + m.lambda * tr;
  r.S[1][1] = 2 * m.mu * e11 + m.lambda * tr;
  r.S[0][1] = r.S[1][0] = 2 * m.mu * e01;
  for (int col = 0; col < 2; ++col) {
    r.c[col][1] = e.dm_inverse[0][col];
    r.c[col][2] = e.dm_inverse[1][col];
    r.c[col][0] = -(e.dm_inverse[0][col] + e.dm_inverse[1][col]);
  }
  return r;
}

// Corotational axes of the deformed triangle and the 9 scalars s of the bending and drilling terms.
template <class T>
struct Bending {
  Vec3T<T> a, b;        // x1 - x0, x2 - x0, m
  T la, ln;             // |a| (m), |a x b| (m^2)
  Vec3T<T> e1, e2, e3;  // corotational axes
  Vec3T<T> d[3][3];     // directors d[i][k] = R_i E_k
  T s[9];               // beta (6), psi (3)
  T phi1[9];            // Phi' = (K_b beta, k_d psi)
  T energy;             // Phi(s) = W_b + W_d, J
  T k_drill;            // k_d, J
};

template <class T>
FASCIA_HD Bending<T> bending(const ShellElementRestT<T>& e, const ShellModuli& m, const Vec3T<T> x[3], const Mat3T<T> R[3]) {
  Bending<T> r;
  r.a = x[1] - x[0];
  r.b = x[2] - x[0];
  const Vec3T<T> n = cross(r.a, r.b);
  r.ln = norm(n);
  r.la = norm(r.a);
  r.e3 = (1 / r.ln) * n;
  r.e1 = (1 / r.la) * r.a;
  r.e2 = cross(r.e3, r.e1);
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) r.d[i][k] = R[i] * e.axes[k];
  for (int i = 0; i < 3; ++i) {
    r.s[2 * i] = -dot(r.e1, r.d[i][2]);
    r.s[2 * i + 1] = -dot(r.e2, r.d[i][2]);
    r.s[6 + i] = 0.5 * (dot(r.e2, r.d[i][0]) - dot(r.e1, r.d[i][1]));
  }
  r.k_drill = m.drilling * e.area;
  r.energy = 0;
  for (int row = 0; row < 6; ++row) {
    T kb = 0;
    for (int col = 0; col < 6; ++col) kb += e.bending[row][col] * r.s[col];
    r.phi1[row] = kb;
    r.energy += 0.5 * kb * r.s[row];
  }
  for (int i = 0; i < 3; ++i) {
    r.phi1[6 + i] = r.k_drill * r.s[6 + i];
    r.energy += 0.5 * r.k_drill * r.s[6 + i] * r.s[6 + i];
  }
  return r;
}

// Jacobians of the corotational axes in a and b (3x3 blocks; d e1 / d b = 0):
//   de1 = P1 da / |a|,  de3 = P3 (-[b]x da + [a]x db) / |n|,  de2 = de3 x e1 + e3 x de1.
template <class T>
struct AxisJacobians {
  Mat3T<T> e1_a, e3_a, e3_b, e2_a, e2_b;
};

template <class T>
FASCIA_HD Mat3T<T> projector_over(const Vec3T<T>& e, T length) {
  Mat3T<T> p = (-1 / length) * outer(e, e);
  for (int k = 0; k < 3; ++k) p.m[k][k] += 1 / length;
  return p;
}

template <class T>
FASCIA_HD AxisJacobians<T> axis_jacobians(const Bending<T>& g) {
  AxisJacobians<T> j;
  j.e1_a = projector_over(g.e1, g.la);
  const Mat3T<T> p3 = projector_over(g.e3, g.ln);
  j.e3_a = (-1.0) * (p3 * skew(g.b));
  j.e3_b = p3 * skew(g.a);
  const Mat3T<T> s1 = skew(g.e1), s3 = skew(g.e3);
  j.e2_a = s3 * j.e1_a - s1 * j.e3_a;
  j.e2_b = (-1.0) * (s1 * j.e3_b);
  return j;
}

// Multipliers C_a,i (shell_element.hpp): e1 . C1 + e2 . C2 = sum_m Phi'_m s_m.
template <class T>
FASCIA_HD void multipliers(const Bending<T>& g, Vec3T<T> C1[3], Vec3T<T> C2[3]) {
  for (int i = 0; i < 3; ++i) {
    const T kbx = g.phi1[2 * i], kby = g.phi1[2 * i + 1], kpsi = g.phi1[6 + i];
    C1[i] = (-kbx) * g.d[i][2] - (0.5 * kpsi) * g.d[i][1];
    C2[i] = (-kby) * g.d[i][2] + (0.5 * kpsi) * g.d[i][0];
  }
}

// The gradient of Phi(s) in (a, b, dr_0, dr_1, dr_2): [J1^T C1 + J2^T C2; C1,i x e1 + C2,i x e2].
template <class T>
FASCIA_HD void bending_gradient(const Bending<T>& g, const AxisJacobians<T>& j, const Vec3T<T> C1[3], const Vec3T<T> C2[3],
                                T* out) {
  const Vec3T<T> c1 = C1[0] + C1[1] + C1[2], c2 = C2[0] + C2[1] + C2[2];
  store3(out, transpose(j.e1_a) * c1 + transpose(j.e2_a) * c2);
  store3(out + 3, transpose(j.e2_b) * c2);
  for (int i = 0; i < 3; ++i) store3(out + 6 + 3 * i, cross(C1[i], g.e1) + cross(C2[i], g.e2));
}

// Second derivative of c . v/|v| in v (the unit-vector formula of the header).
template <class T>
FASCIA_HD Mat3T<T> unit_vector_hessian(const Vec3T<T>& c, const Vec3T<T>& e, T length) {
  const T ce = dot(c, e);
  Mat3T<T> h = (3 * ce) * outer(e, e) - (outer(c, e) + outer(e, c));
  for (int k = 0; k < 3; ++k) h.m[k][k] -= ce;
  return (1 / (length * length)) * h;
}

// Reduced unknowns (a, b, dr_0, dr_1, dr_2) as five blocks of three: 0 = a, 1 = b, 2 + i = dr_i.
constexpr int kReducedBlocks = 5;

// Hessian of Phi(s) in the reduced unknowns, as its 3x3 blocks h[P][Q] on and below the block
// diagonal (P >= Q; overwritten; the blocks above are not set).
template <class T>
FASCIA_HD void bending_hessian(const ShellElementRestT<T>& e, const Bending<T>& g, const AxisJacobians<T>& j,
                               const Vec3T<T> C1i[3], const Vec3T<T> C2i[3], Mat3T<T> (*h)[kReducedBlocks]) {
  // G^T Phi'' G. Row m of G = ds/dtheta is (A_m, r_m): A_m [6] in (a, b), the gradient of
  // e1 . c1 + e2 . c2 through the axes, and r_m = c1 x e1 + c2 x e2 in dr_i of the node i of s_m
  // (rows 2i, 2i + 1, 6 + i), zero in the other nodes' dr.
  const Mat3T<T> J1aT = transpose(j.e1_a), J2aT = transpose(j.e2_a), J2bT = transpose(j.e2_b);
  T A[9][6];
  Vec3T<T> r[9];
  for (int i = 0; i < 3; ++i) {
    const Vec3T<T> beta = -g.d[i][2];                                 // beta_ix: c1; beta_iy: c2
    const Vec3T<T> psi1 = -0.5 * g.d[i][1], psi2 = 0.5 * g.d[i][0];  // psi_i: c1, c2
    store3(A[2 * i], J1aT * beta);
    store3(A[2 * i] + 3, Vec3T<T>{0, 0, 0});
    r[2 * i] = cross(beta, g.e1);
    store3(A[2 * i + 1], J2aT * beta);
    store3(A[2 * i + 1] + 3, J2bT * beta);
    r[2 * i + 1] = cross(beta, g.e2);
    store3(A[6 + i], J1aT * psi1 + J2aT * psi2);
    store3(A[6 + i] + 3, J2bT * psi2);
    r[6 + i] = cross(psi1, g.e1) + cross(psi2, g.e2);
  }
  T Y[9][6];  // Phi'' A, Phi'' = diag(K_b, k_d I)
  for (int m = 0; m < 9; ++m)
    for (int p = 0; p < 6; ++p) {
      T s = 0;
      if (m < 6)
        for (int l = 0; l < 6; ++l) s += e.bending[m][l] * A[l][p];
      else
        s = g.k_drill * A[m][p];
      Y[m][p] = s;
    }
  // (a, b) x (a, b): A^T Phi'' A, its lower triangle mirrored.
  T ab[6][6];
  for (int p = 0; p < 6; ++p)
    for (int q = 0; q <= p; ++q) {
      T s = 0;
      for (int m = 0; m < 9; ++m) s += A[m][p] * Y[m][q];
      ab[p][q] = ab[q][p] = s;
    }
  for (int p = 0; p < 3; ++p)
    for (int q = 0; q < 3; ++q) {
      h[0][0].m[p][q] = ab[p][q];
      h[1][0].m[p][q] = ab[3 + p][q];
      h[1][1].m[p][q] = ab[3 + p][3 + q];
    }
  for (int i = 0; i < 3; ++i) {
    const int rows[3] = {2 * i, 2 * i + 1, 6 + i};
    // dr_i x (a, b): the rows m of node i, r_m (Phi'' A)_m^T.
    Mat3T<T> ha = zero3<T>(), hb = zero3<T>();
    for (int m : rows) {
      ha += outer(r[m], load3(Y[m]));
      hb += outer(r[m], load3(Y[m] + 3));
    }
    h[2 + i][0] = ha;
    h[2 + i][1] = hb;
    // dr_i x dr_k (k <= i): Phi''_ml r_m r_l^T over the rows m of node i and l of node k; K_b
    // couples the beta rows of every pair of nodes, k_d the psi row of a node with itself.
    for (int k = 0; k <= i; ++k) {
      Mat3T<T> rr = zero3<T>();
      for (int b = 0; b < 2; ++b)
        rr += outer(e.bending[2 * i][2 * k + b] * r[2 * i] + e.bending[2 * i + 1][2 * k + b] * r[2 * i + 1],
                    r[2 * k + b]);
      if (k == i) rr += g.k_drill * outer(r[6 + i], r[6 + i]);
      h[2 + i][2 + k] = rr;
    }
  }
  // sum_m Phi'_m Hess(s_m) = Hess(e1 . C1 + e2 . C2) with C_a = sum_i C_a,i frozen.
  const Vec3T<T> C1 = C1i[0] + C1i[1] + C1i[2], C2 = C2i[0] + C2i[1] + C2i[2];
  // (a, b) x (a, b): e1 . C1 + e1 . (C2 x e3) + e3 . (e1 x C2) + the product term of e2.
  h[0][0] += unit_vector_hessian(C1 + cross(C2, g.e3), g.e1, g.la);
  {
    const Vec3T<T> c3 = cross(g.e1, C2);
    const Mat3T<T> Hn = unit_vector_hessian(c3, g.e3, g.ln);
    const Mat3T<T> SaHn = skew_times(g.a, Hn), SbHn = skew_times(g.b, Hn);
    const Mat3T<T> Sa = skew(g.a), Sb = skew(g.b);
    h[0][0] += (-1.0) * (SbHn * Sb);
    h[1][0] += SaHn * Sb + skew((1 / g.ln) * (c3 - dot(c3, g.e3) * g.e3));  // + [P3 c3 / |n|]x
    h[1][1] += (-1.0) * (SaHn * Sa);
  }
  // Product term M + M^T, M = J3^T (-[C2]x) J1 (only the a columns: J1 has no b part).
  {
    const Mat3T<T> SCJ1 = skew_times(C2, j.e1_a);
    const Mat3T<T> Ma = (-1.0) * (transpose(j.e3_a) * SCJ1), Mb = (-1.0) * (transpose(j.e3_b) * SCJ1);
    h[0][0] += Ma + transpose(Ma);
    h[1][0] += Mb;
  }
  for (int i = 0; i < 3; ++i) {
    // dr_i x (a, b): the transpose of -J1^T [C1,i]x - J2^T [C2,i]x, i.e. [C1,i]x J1 + [C2,i]x J2.
    h[2 + i][0] += skew_times(C1i[i], j.e1_a) + skew_times(C2i[i], j.e2_a);
    h[2 + i][1] += skew_times(C2i[i], j.e2_b);
    // dr_i x dr_i: sum_a sym(e_a C_a,i^T) - (e_a . C_a,i) I.
    Mat3T<T> K = 0.5 * (outer(g.e1, C1i[i]) + outer(C1i[i], g.e1) + outer(g.e2, C2i[i]) + outer(C2i[i], g.e2));
    const T diag = dot(g.e1, C1i[i]) + dot(g.e2, C2i[i]);
    for (int k = 0; k < 3; ++k) K.m[k][k] -= diag;
    h[2 + i][2 + i] += K;
  }
}

// dW_m/dU_c = A t sum_d S_cd f_d (c = 0, 1).
template <class T>
FASCIA_HD void membrane_stress_vectors(const ShellElementRestT<T>& e, const ShellModuli& m, const Membrane<T>& mem, Vec3T<T> P[2]) {
  const T at = e.area * m.thickness;
  P[0] = at * (mem.S[0][0] * mem.f[0] + mem.S[0][1] * mem.f[1]);
  P[1] = at * (mem.S[1][0] * mem.f[0] + mem.S[1][1] * mem.f[1]);
}

// The element gradient g[18] from the membrane and the bending gradient gb in (a, b, dr_i).
template <class T>
FASCIA_HD void element_gradient(const Membrane<T>& mem, const Vec3T<T> P[2], const T* gb, T* g) {
  const Vec3T<T> ga = load3(gb), gbb = load3(gb + 3);
  const Vec3T<T> gx[3] = {-(ga + gbb), ga, gbb};  // a = x1 - x0, b = x2 - x0
  for (int i = 0; i < 3; ++i) {
    store3(g + 6 * i, mem.c[0][i] * P[0] + mem.c[1][i] * P[1] + gx[i]);
    store3(g + 6 * i + 3, load3(gb + 6 + 3 * i));
  }
}

// What the gradient and the Hessian share: the membrane and bending states, the axis Jacobians
// and the multipliers, with the element gradient g[18] (overwritten).
template <class T>
struct ElementState {
  Membrane<T> mem;
  Bending<T> bend;
  AxisJacobians<T> j;
  Vec3T<T> C1[3], C2[3];
};

template <class T>
FASCIA_HD ElementState<T> element_state(const ShellElementRestT<T>& e, const ShellModuli& m, const Vec3T<T> x[3], const Mat3T<T> R[3],
                                     T* g) {
  ElementState<T> s{membrane(e, m, x), bending(e, m, x, R), {}, {}, {}};
  s.j = axis_jacobians(s.bend);
  multipliers(s.bend, s.C1, s.C2);
  Vec3T<T> P[2];
  T gb[15];
  bending_gradient(s.bend, s.j, s.C1, s.C2, gb);
  membrane_stress_vectors(e, m, s.mem, P);
  element_gradient(s.mem, P, gb, g);
  return s;
}

}  // namespace shell_detail

// W_e of one triangle (J). x: node positions (m); R: node rotations.
template <class T>
FASCIA_HD T shell_element_energy(const ShellElementRestT<T>& e, const ShellModuli& m, const Vec3T<T> x[3], const Mat3T<T> R[3]) {
  return shell_detail::membrane(e, m, x).energy + shell_detail::bending(e, m, x, R).energy;
}

// W_e and its gradient g[18] in theta (overwritten; J/m for dx, J/rad for dr).
template <class T>
FASCIA_HD T shell_element_gradient(const ShellElementRestT<T>& e, const ShellModuli& m, const Vec3T<T> x[3], const Mat3T<T> R[3],
                                        T* g) {
  const shell_detail::ElementState<T> s = shell_detail::element_state(e, m, x, R, g);
  return s.mem.energy + s.bend.energy;
}

// W_e, its gradient g[18] and its symmetric Hessian H[18][18] (row-major), both overwritten.
template <class T>
FASCIA_HD T shell_element_hessian(const ShellElementRestT<T>& e, const ShellModuli& m, const Vec3T<T> x[3], const Mat3T<T> R[3],
                                       T* g, T* H) {
  using namespace shell_detail;
  constexpr int n = kShellElementDofs;
  const ElementState<T> s = element_state(e, m, x, R, g);
  const Membrane<T>& mem = s.mem;
  // Bending and drilling in (a, b, dr_i), then theta's 3x3 blocks B[P][Q] on and below the block
  // diagonal: dx_i = block 2i, dr_i = block 2i + 1, with x_0 = -(a + b), x_1 = a, x_2 = b.
  Mat3T<T> hr[kReducedBlocks][kReducedBlocks];
  bending_hessian(e, s.bend, s.j, s.C1, s.C2, hr);
  Mat3T<T> B[6][6];
  const Mat3T<T> aa = hr[0][0], ba = hr[1][0], bb = hr[1][1], ab = transpose(ba);
  B[0][0] = aa + ab + ba + bb;
  B[2][0] = (-1.0) * (aa + ab);
  B[2][2] = aa;
  B[4][0] = (-1.0) * (ba + bb);
  B[4][2] = ba;
  B[4][4] = bb;
  for (int i = 0; i < 3; ++i) {
    const Mat3T<T> ra = hr[2 + i][0], rb = hr[2 + i][1];  // dr_i x a, dr_i x b
    const Mat3T<T> r0 = (-1.0) * (ra + rb);                 // dr_i x x_0
    const int row = 2 * i + 1;
    B[row][0] = r0;  // dr_i x x_j, stored below the diagonal as x_j x dr_i where j > i
    if (row > 2) B[row][2] = ra; else B[2][row] = transpose(ra);
    if (row > 4) B[row][4] = rb; else B[4][row] = transpose(rb);
    for (int k = 0; k <= i; ++k) B[row][2 * k + 1] = hr[2 + i][2 + k];
  }
  // Membrane blocks in U: HU[c][d] (3x3 each), then d2W_m/dx_i dx_j = sum_cd c_ci c_dj HU[c][d].
  const T at = e.area * m.thickness;
  const double l = m.lambda, mu = m.mu;
  const Vec3T<T> f0 = mem.f[0], f1 = mem.f[1];
  Mat3T<T> HU[2][2];
  HU[0][0] = at * ((2 * mu + l) * outer(f0, f0) + mu * outer(f1, f1));
  HU[1][1] = at * ((2 * mu + l) * outer(f1, f1) + mu * outer(f0, f0));
  HU[0][1] = at * (l * outer(f0, f1) + mu * outer(f1, f0));
  HU[1][0] = transpose(HU[0][1]);
  for (int c = 0; c < 2; ++c)
    for (int d = 0; d < 2; ++d)
      for (int k = 0; k < 3; ++k) HU[c][d].m[k][k] += at * mem.S[c][d];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b <= a; ++b)
      B[2 * a][2 * b] += (mem.c[0][a] * mem.c[0][b]) * HU[0][0] + (mem.c[0][a] * mem.c[1][b]) * HU[0][1] +
                         (mem.c[1][a] * mem.c[0][b]) * HU[1][0] + (mem.c[1][a] * mem.c[1][b]) * HU[1][1];
  // H from its lower triangle: exactly symmetric (K_b and the blocks' products are symmetric only
  // to round-off).
  for (int P = 0; P < 6; ++P) {
    for (int Q = 0; Q < P; ++Q)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) H[n * (3 * P + r) + 3 * Q + c] = H[n * (3 * Q + c) + 3 * P + r] = B[P][Q].m[r][c];
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c <= r; ++c) H[n * (3 * P + r) + 3 * P + c] = H[n * (3 * P + c) + 3 * P + r] = B[P][P].m[r][c];
  }
  return mem.energy + s.bend.energy;
}

}  // namespace fascia
