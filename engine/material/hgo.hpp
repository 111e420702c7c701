// Fibre-reinforced hyperelasticity after Holzapfel, Gasser & Ogden (J. Elasticity 61:1-48, 2000,
// eq. 55) with the fibre dispersion of Gasser, Ogden & Holzapfel (J. R. Soc. Interface 3:15-35,
// 2006, eq. 2.8): one fibre family, or two at +-gamma about a mean direction in a plane, in one of
// two formulations, as FEBio's two HGO materials (FEBio User's Manual, "Holzapfel-Gasser-Ogden"
// among the uncoupled materials and "HGO unconstrained" among the unconstrained ones):
//
// coupled, unmodified invariants (FEBio "HGO unconstrained"; Nolan et al., J. Mech. Behav. Biomed.
// Mater. 39:48-60, 2014, show that the uncoupled form's isochoric I4 misses the fibres' volumetric
// response in compressible use):
//   psi   = psi_nh(F) + sum_k psi_f(E_k),   E_k = kappa (I1 - 3) + (1 - 3 kappa)(I4_k - 1) = H_k : C - 1
// with psi_nh the compressible neo-Hookean ground substance of neo_hookean.hpp;
//
// uncoupled, isochoric/volumetric split (FEBio "Holzapfel-Gasser-Ogden", the form of Gasser, Ogden
// & Holzapfel 2006 with two families):
//   psi   = mu/2 (I1bar - 3) + U(J) + sum_k psi_f(Ebar_k),   U(J) = K/2 (ln J)^2,  K = lambda + 2 mu / 3
//   Ebar_k = kappa (I1bar - 3) + (1 - 3 kappa)(I4bar_k - 1) = H_k : Cbar - 1 = J^{-2/3} H_k : C - 1
// with FEBio's default volumetric energy U (its uncoupled materials' k (ln J)^2 / 2) and the
// fibres on the isochoric invariants I4bar_k = a_k . Cbar a_k, as FEBio evaluates them: the energy
// splits exactly into an isochoric part and U(J), so the volume change answers the bulk modulus K
// alone (a pure dilatation F = a I meets P = K ln J F^{-T}, fibres or not) and a nearly
// incompressible tissue (K >> mu, k1) keeps J near 1 under fibre loads; there J -> 1 and the
// two formulations agree (they have equal energies wherever det F = 1).
//
// Common to both:
//   psi_f(E) = k1 / (2 k2) (exp(k2 <E>^2) - 1),   <x> = max(x, 0): the fibres bear load in tension only
//   H_k   = kappa I + (1 - 3 kappa) a_k (x) a_k     generalised structure tensor (tr H_k = 1)
//   C     = F^T F,  Cbar = J^{-2/3} C,  I1 = tr C,  I4_k = a_k . C a_k,  J = det F
//   a_0   = e1 (one family), or a_{0,1} = cos(gamma) e1 +- sin(gamma) e2 (two families)
// with e1 the unit mean direction and e2 the unit vector of the families' plane orthogonal to it
// (all at rest, world axes), kappa in [0, 1/3] (0: aligned fibres, 1/3: isotropic dispersion).
// FEBio's uncoupled material switches a family on where I4bar_k > 1 rather than Ebar_k > 0: the
// two agree for kappa = 0, and since I1bar >= 3, I4bar_k > 1 implies Ebar_k > 0.
//
// Derivatives, with g = dpsi_f/dE = k1 <E> exp(k2 <E>^2) and g' = d^2 psi_f / dE^2 =
// k1 (1 + 2 k2 E^2) exp(k2 E^2) for E > 0 (0 otherwise), and D_k = dE_k/dF:
//   P_f   = sum_k g D_k,   dP_f = sum_k g' (D_k : dF) D_k + g dD_k
//   coupled:    D_k = 2 F H_k, dD_k = 2 dF H_k
//   uncoupled:  D_k, dD_k of phi_{H_k} (isochoric.hpp, eq. I1 and I2); the ground substance is
//               mu/2 phi_I, and U gives P_U = K ln J G, dP_U = K (G : dF) G - K ln J G dF^T G
//               (G = F^{-T}).
// k1 and mu, lambda, K in Pa; k2, kappa and gamma (rad) dimensionless. The fibre stretch reported
// (stress_measures.hpp) is |F e1| = sqrt(I4) along the mean direction. The fibre terms need F
// only: the tangent recomputes g and g' from F rather than caching them.
#pragma once

#include "core/small_math.hpp"
#include "material/isochoric.hpp"

#include <cmath>

namespace fascia {

enum class HgoFormulation : int { coupled = 0, uncoupled = 1 };

// The fibres: stiffness k1 (Pa), exponent k2 (> 0), dispersion kappa in [0, 1/3], the unit mean
// direction e1 in rest (world) axes, and for two families their half-angle gamma and their plane.
// `axes` are derived from the others by with_fibre_direction (material.hpp), which every maker
// of a material goes through.
struct Fibres {
  double k1 = 0;
  double k2 = 1;
  double dispersion = 0;
  Vec3 direction{0, 0, 0};  // e1, unit
  int families = 1;         // 1 or 2
  double angle = 0;         // gamma in [0, pi/2], rad (two families)
  Vec3 plane{0, 0, 0};      // two families: a vector of their plane, not parallel to e1 (as FEBio's mat_axis d)
  Vec3 axes[2]{};           // unit a_k at rest: e1 (one family); cos(gamma) e1 +- sin(gamma) e2 (two)
};

// H_k = kappa I + (1 - 3 kappa) a_k (x) a_k.
template <class T>
FASCIA_HD Mat3T<T> fibre_structure_tensor(const Fibres& f, int k) {
  const Vec3& d = f.axes[k];
  const Vec3T<T> a{static_cast<T>(d.x), static_cast<T>(d.y), static_cast<T>(d.z)};
  Mat3T<T> H = static_cast<T>(1 - 3 * f.dispersion) * outer(a, a);
  const T kappa = static_cast<T>(f.dispersion);
  H.m[0][0] += kappa;
  H.m[1][1] += kappa;
  H.m[2][2] += kappa;
  return H;
}

// Fibre stretch along the mean direction |F e1| (dimensionless, 1 at rest).
FASCIA_HD double fibre_stretch(const Fibres& f, const Mat3& F) { return norm(F * f.direction); }

// sum_k psi_f(E_k) in J/m^3 with E_k = j (F : F H_k) - 1: j = 1 (coupled) or J^{-2/3} (uncoupled).
FASCIA_HD double fibre_energy(const Fibres& f, const Mat3& F, double j) {
  double psi = 0;
  for (int k = 0; k < f.families; ++k) {
    const double e = isochoric_invariant(F, fibre_structure_tensor<double>(f, k), j) - 1;
    if (e > 0) psi += 0.5 * f.k1 / f.k2 * std::expm1(f.k2 * e * e);
  }
  return psi;
}

// P_f(F) in Pa; G = F^{-T} and j = J^{-2/3} for the uncoupled form (j = 1, G unused, coupled).
template <class T>
FASCIA_HD Mat3T<T> fibre_first_piola(const Fibres& f, const Mat3T<T>& F, bool uncoupled, const Mat3T<T>& G,
                                     Scalar<T> j) {
  Mat3T<T> P = zero3<T>();
  for (int k = 0; k < f.families; ++k) {
    const Mat3T<T> H = fibre_structure_tensor<T>(f, k);
    const T e = isochoric_invariant(F, H, j) - T(1);
    if (!(e > T(0))) continue;
    const T g = static_cast<T>(f.k1) * e * std::exp(static_cast<T>(f.k2) * e * e);
    P += g * (uncoupled ? isochoric_invariant_gradient(F, H, G, j) : T(2) * (F * H));
  }
  return P;
}

// dP_f = (d^2 psi_f / dF^2) : dF at F (arguments as fibre_first_piola).
template <class T>
FASCIA_HD Mat3T<T> fibre_pk1_differential(const Fibres& f, const Mat3T<T>& F, bool uncoupled, const Mat3T<T>& G,
                                          Scalar<T> j, const Mat3T<T>& dF) {
  Mat3T<T> dP = zero3<T>();
  const T k1 = static_cast<T>(f.k1), k2 = static_cast<T>(f.k2);
  for (int k = 0; k < f.families; ++k) {
    const Mat3T<T> H = fibre_structure_tensor<T>(f, k);
    const T e = isochoric_invariant(F, H, j) - T(1);
    if (!(e > T(0))) continue;
    const T x = std::exp(k2 * e * e);
    const T g = k1 * e * x, g_prime = k1 * (T(1) + T(2) * k2 * e * e) * x;
    const Mat3T<T> D = uncoupled ? isochoric_invariant_gradient(F, H, G, j) : T(2) * (F * H);
    const Mat3T<T> dD = uncoupled ? isochoric_invariant_differential(F, H, G, j, dF) : T(2) * (dF * H);
    dP += (g_prime * ddot(D, dF)) * D + g * dD;
  }
  return dP;
}

// The uncoupled form: psi(F) in J/m^3, +infinity for det F <= 0 (inverted).
FASCIA_HD double hgo_uncoupled_energy(double lambda, double mu, const Fibres& f, const Mat3& F) {
  const double J = det(F);
  if (!(J > 0)) return HUGE_VAL;
  const double ln_j = std::log(J), j = std::exp(-2.0 / 3 * ln_j), K = lambda + 2.0 / 3 * mu;
  return 0.5 * mu * (isochoric_invariant(F, identity3<double>(), j) - 3) + 0.5 * K * ln_j * ln_j +
         fibre_energy(f, F, j);
}

// The uncoupled form: P(F) in Pa; fills f_inv_t = F^{-T} and ln_j = ln J for the differential.
// @pre det F > 0.
FASCIA_HD Mat3 hgo_uncoupled_first_piola(double lambda, double mu, const Fibres& f, const Mat3& F, Mat3& f_inv_t,
                                         double& ln_j) {
  const double J = det(F);
  ln_j = std::log(J > 0 ? J : 1e-300);
  f_inv_t = inverse_transpose(F);
  const double j = std::exp(-2.0 / 3 * ln_j), K = lambda + 2.0 / 3 * mu;
  return (0.5 * mu) * isochoric_invariant_gradient(F, identity3<double>(), f_inv_t, j) + (K * ln_j) * f_inv_t +
         fibre_first_piola(f, F, true, f_inv_t, j);
}

// The uncoupled form: dP = (d^2 psi / dF^2) : dF at F, with f_inv_t and ln_j from
// hgo_uncoupled_first_piola.
template <class T>
FASCIA_HD Mat3T<T> hgo_uncoupled_pk1_differential(Scalar<T> lambda, Scalar<T> mu, const Fibres& f, const Mat3T<T>& F,
                                                  const Mat3T<T>& f_inv_t, Scalar<T> ln_j, const Mat3T<T>& dF) {
  const T j = std::exp(T(-2) / T(3) * ln_j), K = lambda + T(2) / T(3) * mu;
  const Mat3T<T>& G = f_inv_t;
  return (T(0.5) * mu) * isochoric_invariant_differential(F, identity3<T>(), G, j, dF) + (K * ddot(G, dF)) * G -
         (K * ln_j) * (G * transpose(dF) * G) + fibre_pk1_differential(f, F, true, G, j, dF);
}

}  // namespace fascia
