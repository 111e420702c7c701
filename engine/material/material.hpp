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

// hgo: the neo-Hookean ground substance plus one fibre family (hgo.hpp).
enum class MaterialLaw : int { stvk = 0, neo_hookean = 1, hgo = 2 };

// One entry of Model::materials. A fibre field that varies in space gives each sample its own
// entry (the direction differs), so every law reads its parameters from here alone.
struct Material {
  MaterialLaw law = MaterialLaw::stvk;
  double lambda = 0;   // first Lame coefficient, Pa
  double mu = 0;       // shear modulus, Pa
  double density = 0;  // kg/m^3
  Fibres fibres;       // hgo only
};

// Lame coefficients from Young's modulus E (Pa) and Poisson ratio nu.
// @pre E > 0, -1 < nu < 0.5 (throws std::invalid_argument otherwise).
Material make_material(MaterialLaw law, double young, double poisson, double density);

// An hgo material: the ground substance from (young, poisson) as make_material, and the fibres.
// The direction is normalised. @pre k1 >= 0, k2 > 0, 0 <= dispersion <= 1/3, |direction| > 0
// (throws std::invalid_argument otherwise).
Material make_hgo_material(double young, double poisson, double density, const Fibres& fibres);

// The same material with another fibre direction (normalised; throws on a zero vector).
Material with_fibre_direction(Material m, const Vec3& direction);

const char* to_string(MaterialLaw law);

// Per-sample quantities reused by every tangent product of one Newton iteration.
// StVK: a = S (second Piola-Kirchhoff). Neo-Hookean and hgo (its ground substance): a = F^{-T},
// c = mu - lambda ln J; hgo's fibre terms are recomputed from F (hgo.hpp).
template <class T>
struct MaterialCacheT {
  Mat3T<T> a;
  T c;
};
using MaterialCache = MaterialCacheT<double>;

// psi(F) in J/m^3; +infinity for a neo-Hookean element with det F <= 0 (inverted).
FASCIA_HD double energy_density(const Material& m, const Mat3& F) {
  if (m.law == MaterialLaw::stvk) return stvk_energy(m.lambda, m.mu, F);
  const double psi = neo_hookean_energy(m.lambda, m.mu, F);
  return m.law == MaterialLaw::hgo ? psi + fibre_energy(m.fibres, F) : psi;
}

// P(F) and the cache for pk1_differential.
FASCIA_HD Mat3 first_piola(const Material& m, const Mat3& F, MaterialCache& cache) {
  if (m.law == MaterialLaw::stvk) {
    cache.a = stvk_second_piola(m.lambda, m.mu, F);
    cache.c = 0;
    return F * cache.a;
  }
  const Mat3 P = neo_hookean_first_piola(m.lambda, m.mu, F, cache.a, cache.c);
  return m.law == MaterialLaw::hgo ? P + fibre_first_piola(m.fibres, F) : P;
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
// Fibres = false leaves out hgo's fibre term (its ground substance alone), for a kernel that
// serves only models without fibres and must not carry the fibre code in its registers.
template <class T, bool Fibres = true>
FASCIA_HD Mat3T<T> pk1_differential(const Material& m, const Mat3T<T>& F, const MaterialCacheT<T>& cache,
                                    const Mat3T<T>& dF) {
  if (m.law == MaterialLaw::stvk)
    return stvk_pk1_differential<T>(static_cast<T>(m.lambda), static_cast<T>(m.mu), F, cache.a, dF);
  const Mat3T<T> dP =
      neo_hookean_pk1_differential<T>(static_cast<T>(m.lambda), static_cast<T>(m.mu), cache.a, cache.c, dF);
  if constexpr (Fibres)
    if (m.law == MaterialLaw::hgo) return dP + fibre_pk1_differential<T>(m.fibres, F, dF);
  return dP;
}

}  // namespace fascia
