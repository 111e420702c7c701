// Fibre-reinforced hyperelasticity after Holzapfel, Gasser & Ogden (J. Elasticity 61:1-48, 2000,
// eq. 55) with the fibre dispersion of Gasser, Ogden & Holzapfel (J. R. Soc. Interface 3:15-35,
// 2006, eq. 2.8), in the coupled form with unmodified invariants (as FEBio's "HGO unconstrained"
// material; Nolan et al., J. Mech. Behav. Biomed. Mater. 39:48-60, 2014, show that the uncoupled
// form's isochoric I4 misses the fibres' volumetric response in compressible use):
//   psi   = psi_nh(F) + k1 / (2 k2) (exp(k2 <E_f>^2) - 1)
//   E_f   = kappa (I1 - 3) + (1 - 3 kappa)(I4 - 1) = H : C - 1
//   H     = kappa I + (1 - 3 kappa) a (x) a      generalised structure tensor (tr H = 1)
//   C     = F^T F,  I1 = tr C,  I4 = a . C a      a = unit fibre direction at rest
// with psi_nh the compressible neo-Hookean ground substance of neo_hookean.hpp and <x> = max(x, 0):
// the fibres bear load in tension only. One fibre family; kappa in [0, 1/3] (0: aligned fibres,
// 1/3: isotropic dispersion). With g = dpsi_f/dE_f = k1 <E_f> exp(k2 <E_f>^2) and
// g' = d^2 psi_f / dE_f^2 = k1 (1 + 2 k2 E_f^2) exp(k2 E_f^2) for E_f > 0 (0 otherwise):
//   P_f   = 2 g F H                                      (dE_f = 2 (F H) : dF)
//   dP_f  = 2 g dF H + 4 g' ((F H) : dF) F H
// k1 in Pa, k2 and kappa dimensionless. The fibre stretch is |F a| = sqrt(I4).
// The fibre terms need F only: the tangent recomputes g and g' from F rather than caching them.
#pragma once

#include "core/small_math.hpp"

#include <cmath>

namespace fascia {

// One fibre family: stiffness k1 (Pa), exponent k2 (> 0), dispersion kappa in [0, 1/3] and the
// unit direction a in rest (world) axes.
struct Fibres {
  double k1 = 0;
  double k2 = 1;
  double dispersion = 0;
  Vec3 direction{0, 0, 0};
};

// H = kappa I + (1 - 3 kappa) a (x) a.
template <class T>
FASCIA_HD Mat3T<T> fibre_structure_tensor(const Fibres& f) {
  const Vec3T<T> a{static_cast<T>(f.direction.x), static_cast<T>(f.direction.y), static_cast<T>(f.direction.z)};
  Mat3T<T> H = static_cast<T>(1 - 3 * f.dispersion) * outer(a, a);
  const T kappa = static_cast<T>(f.dispersion);
  H.m[0][0] += kappa;
  H.m[1][1] += kappa;
  H.m[2][2] += kappa;
  return H;
}

// Fibre stretch |F a| (dimensionless, 1 at rest).
FASCIA_HD double fibre_stretch(const Fibres& f, const Mat3& F) { return norm(F * f.direction); }

// psi_f(F) in J/m^3.
FASCIA_HD double fibre_energy(const Fibres& f, const Mat3& F) {
  const double e = ddot(fibre_structure_tensor<double>(f), transpose(F) * F) - 1;
  if (!(e > 0)) return 0;
  return 0.5 * f.k1 / f.k2 * std::expm1(f.k2 * e * e);
}

// P_f(F) in Pa.
FASCIA_HD Mat3 fibre_first_piola(const Fibres& f, const Mat3& F) {
  const Mat3 FH = F * fibre_structure_tensor<double>(f);
  const double e = ddot(F, FH) - 1;  // H : F^T F = F : F H
  if (!(e > 0)) return zero3();
  return (2 * f.k1 * e * std::exp(f.k2 * e * e)) * FH;
}

// dP_f = (d^2 psi_f / dF^2) : dF at F.
template <class T>
FASCIA_HD Mat3T<T> fibre_pk1_differential(const Fibres& f, const Mat3T<T>& F, const Mat3T<T>& dF) {
  const Mat3T<T> H = fibre_structure_tensor<T>(f);
  const Mat3T<T> FH = F * H;
  const T e = ddot(F, FH) - T(1);
  if (!(e > T(0))) return zero3<T>();
  const T k1 = static_cast<T>(f.k1), k2 = static_cast<T>(f.k2);
  const T x = std::exp(k2 * e * e);
  const T g = k1 * e * x, g_prime = k1 * (T(1) + T(2) * k2 * e * e) * x;
  return (T(2) * g) * (dF * H) + (T(4) * g_prime * ddot(FH, dF)) * FH;
}

}  // namespace fascia
