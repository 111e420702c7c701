// Isochoric invariants of the multiplicative split F = J^{1/3} Fbar (Flory, Trans. Faraday Soc.
// 57:829-838, 1961; Holzapfel, Nonlinear Solid Mechanics, 2000, §6.4), on which uncoupled laws
// write their isochoric energy. For a symmetric A of the rest axes (A = I gives I1bar, A = a (x) a
// gives I4bar):
//   phi_A(F) = tr(A Cbar) = j (F : F A),   Cbar = J^{-2/3} C,  C = F^T F,  j = J^{-2/3},  J = det F
// With G = F^{-T} (dJ = J G : dF, dG = -G dF^T G, so dj = -2/3 j G : dF) and q = F : F A:
//   D_A  = dphi_A / dF = j (2 F A - 2/3 q G)                                                  (I1)
//   dD_A = -2/3 (G : dF) D_A + j (2 dF A - 4/3 ((F A) : dF) G + 2/3 q G dF^T G)                 (I2)
// dD_A is symmetric as a bilinear form in dF (a Hessian of phi_A). phi_A is unchanged by F -> a F
// (a > 0): a pure dilatation leaves every isochoric invariant at its rest value. All
// dimensionless; F, A, G 3x3 row-major.
#pragma once

#include "core/small_math.hpp"

namespace fascia {

// phi_A(F) = j (F : F A).
template <class T>
FASCIA_HD T isochoric_invariant(const Mat3T<T>& F, const Mat3T<T>& A, Scalar<T> j) {
  return j * ddot(F, F * A);
}

// D_A = dphi_A / dF, eq. (I1).
template <class T>
FASCIA_HD Mat3T<T> isochoric_invariant_gradient(const Mat3T<T>& F, const Mat3T<T>& A, const Mat3T<T>& G,
                                                Scalar<T> j) {
  const Mat3T<T> FA = F * A;
  const T q = ddot(F, FA);
  return j * (T(2) * FA - (T(2) / T(3) * q) * G);
}

// dD_A = (d^2 phi_A / dF^2) : dF, eq. (I2).
template <class T>
FASCIA_HD Mat3T<T> isochoric_invariant_differential(const Mat3T<T>& F, const Mat3T<T>& A, const Mat3T<T>& G,
                                                    Scalar<T> j, const Mat3T<T>& dF) {
  const Mat3T<T> FA = F * A;
  const T q = ddot(F, FA);
  const Mat3T<T> D = j * (T(2) * FA - (T(2) / T(3) * q) * G);
  return (-T(2) / T(3) * ddot(G, dF)) * D +
         j * (T(2) * (dF * A) - (T(4) / T(3) * ddot(FA, dF)) * G + (T(2) / T(3) * q) * (G * transpose(dF) * G));
}

}  // namespace fascia
