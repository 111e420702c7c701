// Constitutive laws behind one interface: energy density psi(F), first Piola-Kirchhoff stress
// P = dpsi/dF and its differential dP[dF], all in SI units (Pa = J/m^3).
//
// The frame method (paper eq. 18-26) works with the Green-Lagrange strain E (eq. 5) and the second
// Piola-Kirchhoff stress S (eq. 19); P = F S. Writing the interface in (F, P) lets laws that are
// not functions of E alone (neo-Hookean, HGO) share the same force and tangent code.
#pragma once

#include "core/small_math.hpp"
#include "material/hgo.hpp"
#include "material/neo_hookean.hpp"
#include "material/stvk.hpp"

#include <string>

namespace fascia {

// hgo: a ground substance reinforced by one or two fibre families, coupled (the neo-Hookean ground
// substance plus the fibres) or uncoupled (isochoric/volumetric split), hgo.hpp.
enum class MaterialLaw : int { stvk = 0, neo_hookean = 1, hgo = 2 };

// One entry of Model::materials. A fibre field that varies in space gives each sample its own
// entry (the direction differs), so every law reads its parameters from here alone.
struct Material {
  MaterialLaw law = MaterialLaw::stvk;
  double lambda = 0;   // first Lame coefficient, Pa
  double mu = 0;       // shear modulus, Pa
  double density = 0;  // kg/m^3
  Fibres fibres;       // hgo only
  HgoFormulation formulation = HgoFormulation::coupled;  // hgo only
};

// Lame coefficients from Young's modulus E (Pa) and Poisson ratio nu.
// @pre E > 0, -1 < nu < 0.5 (throws std::invalid_argument otherwise).
Material make_material(MaterialLaw law, double young, double poisson, double density);

// An hgo material: the ground substance from (young, poisson) as make_material (the uncoupled
// form's bulk modulus K = lambda + 2 mu / 3 = young / (3 (1 - 2 poisson))), and the fibres. The
// direction and plane are normalised and the axes derived (with_fibre_direction).
// @pre k1 >= 0, k2 > 0, 0 <= dispersion <= 1/3, |direction| > 0, families 1 or 2; with two
// families 0 <= angle <= pi/2 and plane not parallel to direction (throws std::invalid_argument
// otherwise).
Material make_hgo_material(double young, double poisson, double density, const Fibres& fibres,
                           HgoFormulation formulation = HgoFormulation::coupled);

// The same material with another mean fibre direction (normalised) and the fibre axes derived
// from it: e1 for one family; cos(angle) e1 +- sin(angle) e2 for two, e2 the unit part of the
// plane vector orthogonal to e1. Throws std::invalid_argument on a zero or non-finite direction
// and, with two families, on a plane vector (nearly) parallel to it.
Material with_fibre_direction(Material m, const Vec3& direction);

const char* to_string(MaterialLaw law);

// Per-sample quantities reused by every tangent product of one Newton iteration.
// StVK: a = S (second Piola-Kirchhoff). Neo-Hookean and coupled hgo (its ground substance):
// a = F^{-T}, c = mu - lambda ln J. Uncoupled hgo: a = F^{-T}, c = ln J. hgo's fibre terms are
// recomputed from F (hgo.hpp).
template <class T>
struct MaterialCacheT {
  Mat3T<T> a;
  T c;
};
using MaterialCache = MaterialCacheT<double>;

// psi(F) in J/m^3; +infinity for a neo-Hookean or hgo element with det F <= 0 (inverted).
FASCIA_HD double energy_density(const Material& m, const Mat3& F) {
  if (m.law == MaterialLaw::stvk) return stvk_energy(m.lambda, m.mu, F);
  const bool hgo = m.law == MaterialLaw::hgo;
  if (hgo && m.formulation == HgoFormulation::uncoupled) return hgo_uncoupled_energy(m.lambda, m.mu, m.fibres, F);
  const double psi = neo_hookean_energy(m.lambda, m.mu, F);
  return hgo ? psi + fibre_energy(m.fibres, F, 1.0) : psi;
}

// P(F) and the cache for pk1_differential.
FASCIA_HD Mat3 first_piola(const Material& m, const Mat3& F, MaterialCache& cache) {
  if (m.law == MaterialLaw::stvk) {
    cache.a = stvk_second_piola(m.lambda, m.mu, F);
    cache.c = 0;
    return F * cache.a;
  }
  const bool hgo = m.law == MaterialLaw::hgo;
  if (hgo && m.formulation == HgoFormulation::uncoupled)
    return hgo_uncoupled_first_piola(m.lambda, m.mu, m.fibres, F, cache.a, cache.c);
  const Mat3 P = neo_hookean_first_piola(m.lambda, m.mu, F, cache.a, cache.c);
  return hgo ? P + fibre_first_piola(m.fibres, F, false, cache.a, 1.0) : P;
}

// psi(F) and P(F) together (StVK computes E once); psi as energy_density, P and cache as
// first_piola.
FASCIA_HD Mat3 energy_and_first_piola(const Material& m, const Mat3& F, MaterialCache& cache, double& psi) {
  if (m.law == MaterialLaw::stvk) {
    const Mat3 E = green_lagrange_strain(F);
    const double tr = trace(E);
    psi = 0.5 * m.lambda * tr * tr + m.mu * ddot(E, E);
    cache.a = stvk_stress_from_strain(m.lambda, m.mu, E);
    cache.c = 0;
    return F * cache.a;
  }
  psi = energy_density(m, F);
  return first_piola(m, F, cache);
}

// dP = (d^2 psi / dF^2) : dF at the state described by F and cache. T = float evaluates the same
// expressions in single precision (the CUDA backend's single-precision tangent product).
// Fibres = false leaves out the hgo code (its fibre terms and its uncoupled form), for a kernel
// that serves only models without an hgo material and must not carry that code in its registers.
template <class T, bool Fibres = true>
FASCIA_HD Mat3T<T> pk1_differential(const Material& m, const Mat3T<T>& F, const MaterialCacheT<T>& cache,
                                    const Mat3T<T>& dF) {
  if (m.law == MaterialLaw::stvk)
    return stvk_pk1_differential<T>(static_cast<T>(m.lambda), static_cast<T>(m.mu), F, cache.a, dF);
  if constexpr (Fibres)
    if (m.law == MaterialLaw::hgo && m.formulation == HgoFormulation::uncoupled)
      return hgo_uncoupled_pk1_differential<T>(static_cast<T>(m.lambda), static_cast<T>(m.mu), m.fibres, F, cache.a,
                                               cache.c, dF);
  const Mat3T<T> dP =
      neo_hookean_pk1_differential<T>(static_cast<T>(m.lambda), static_cast<T>(m.mu), cache.a, cache.c, dF);
  if constexpr (Fibres)
    if (m.law == MaterialLaw::hgo) return dP + fibre_pk1_differential<T>(m.fibres, F, false, cache.a, T(1), dF);
  return dP;
}

}  // namespace fascia
