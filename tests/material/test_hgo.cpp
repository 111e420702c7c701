// The fibre-reinforced law (material/hgo.hpp), coupled and uncoupled, with one fibre family or
// two: stress and tangent against finite differences, uniaxial tension along and across the
// fibres against the closed form, rigid-motion invariance, the uncoupled form's volumetric split,
// the fibre stretch and the refusal of invalid parameters.
#include "core/rotation.hpp"
#include "material/material.hpp"
#include "material/stress_measures.hpp"
#include "support/finite_difference.hpp"
#include "support/hgo_uniaxial.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;
using namespace fascia::test;

namespace {

// Ground substance E = 10 kPa, nu = 0.45; fibres k1 = 50 kPa, k2 = 5 (ligament-like magnitudes).
Material ligament(double dispersion, const Vec3& direction) {
  return make_hgo_material(1e4, 0.45, 1000, Fibres{5e4, 5, dispersion, direction});
}

// The law's variants: formulation, and one fibre family or two.
struct Variant {
  HgoFormulation formulation;
  int families;
};
const char* name(HgoFormulation f) { return f == HgoFormulation::coupled ? "coupled" : "uncoupled"; }

// The ligament of a variant; two families lie at +-angle (default 1 rad, 57 deg: with the default
// plane, every family's |E_k| > 0.05 at the states of state_F) about `direction` in its plane
// with `plane`.
Material ligament(const Variant& v, double dispersion, const Vec3& direction, const Vec3& plane = Vec3{0.1, 0.3, 0.9},
                  double angle = 1.0, double k1 = 5e4) {
  Fibres f{k1, 5, dispersion, direction};
  f.families = v.families;
  f.angle = angle;
  f.plane = plane;
  return make_hgo_material(1e4, 0.45, 1000, f, v.formulation);
}

// E_k of family k at F: H_k : C - 1 (coupled) or J^{-2/3} H_k : C - 1 (uncoupled).
double fibre_strain(const Material& m, const Mat3& F, int k) {
  const double j = m.formulation == HgoFormulation::uncoupled ? std::pow(det(F), -2.0 / 3) : 1.0;
  return j * ddot(fibre_structure_tensor<double>(m.fibres, k), transpose(F) * F) - 1;
}

double frobenius(const Mat3& a) { return std::sqrt(ddot(a, a)); }

template <class To, class From>
Mat3T<To> cast(const Mat3T<From>& a) {
  Mat3T<To> out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.m[r][c] = static_cast<To>(a.m[r][c]);
  return out;
}

// Deformation gradients at which the fibres are stretched (E_f > 0), compressed (E_f < 0, the
// ground substance alone) and strongly stretched and sheared.
Mat3 state_F(int k) {
  if (k == 0) return Mat3{{{1.1, 0.2, -0.05}, {0.03, 0.9, 0.1}, {-0.1, 0.05, 1.2}}};
  if (k == 1) return Mat3{{{0.85, 0.05, 0.02}, {-0.04, 1.05, 0.1}, {0.03, -0.02, 1.1}}};
  return Mat3{{{1.3, 0.35, 0.1}, {-0.2, 0.95, 0.15}, {0.05, -0.1, 0.9}}};
}

}  // namespace

// Each of the four variants in turn (a Catch2 generator of the test case that uses it).
#define HGO_VARIANTS                                                                                                  \
  GENERATE(Variant{HgoFormulation::coupled, 1}, Variant{HgoFormulation::coupled, 2},                                 \
           Variant{HgoFormulation::uncoupled, 1}, Variant{HgoFormulation::uncoupled, 2})

TEST_CASE("hgo: P = dpsi/dF and dP = dP/dF by central differences", "[material][hgo][fd]") {
  const Variant v = HGO_VARIANTS;
  const double dispersion = GENERATE(0.0, 0.2);
  const int k = GENERATE(0, 1, 2);
  const Material m = ligament(v, dispersion, Vec3{0.8, 0.5, -0.3});
  const Mat3 F = state_F(k);
  INFO(name(v.formulation) << ", " << v.families << " families, dispersion " << dispersion << ", state " << k);
  // Away from the kink of <E_k> at 0 (the differences below span |dE_k| < 1e-4).
  for (int f = 0; f < v.families; ++f) {
    INFO("family " << f << ": E " << fibre_strain(m, F, f));
    REQUIRE(std::abs(fibre_strain(m, F, f)) > 1e-2);
  }
  MaterialCache cache;
  const Mat3 P = first_piola(m, F, cache);
  // Central differences with h = cbrt(eps) = 6e-6 (tests/support/finite_difference.hpp): truncation
  // h^2 |psi'''| / 6 and round-off eps |psi| / h are both ~1e-10 relative for |F| ~ 1 and the
  // exponential's derivatives of order k2^2 = 25; 1e-6 relative leaves room for those factors and
  // is far below any wrong term (O(1) relative).
  const double h = 6e-6;
  const Mat3 gradient_fd = test::central_difference([&](const Mat3& X) { return energy_density(m, X); }, F, h);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) REQUIRE(std::abs(gradient_fd.m[r][c] - P.m[r][c]) <= 1e-6 * frobenius(P));
  double psi = 0;
  MaterialCache cache2;
  const Mat3 P2 = energy_and_first_piola(m, F, cache2, psi);
  REQUIRE(psi == energy_density(m, F));
  REQUIRE(frobenius(P2 - P) == 0.0);
  const Mat3 dF = Mat3{{{0.3, -0.2, 0.1}, {0.5, 0.1, -0.4}, {0.2, 0.3, 0.6}}};
  const Mat3 dP = pk1_differential(m, F, cache, dF);
  MaterialCache cp, cm;
  const Mat3 fd = (1 / (2 * h)) * (first_piola(m, F + h * dF, cp) - first_piola(m, F - h * dF, cm));
  REQUIRE(frobenius(fd - dP) <= 1e-6 * frobenius(dP));
  // The tangent is symmetric: dF2 : dP[dF] = dF : dP[dF2] (a Hessian of psi); rounding 1e-16.
  const Mat3 dF2 = Mat3{{{-0.1, 0.4, 0.2}, {0.3, -0.5, 0.1}, {0.6, 0.2, -0.3}}};
  const double a = ddot(dF2, dP), b = ddot(dF, pk1_differential(m, F, cache, dF2));
  REQUIRE(std::abs(a - b) <= 1e-12 * frobenius(dP) * frobenius(dF2));
  // Single precision evaluates the same expressions (unit roundoff 6e-8; the fibre term is a
  // difference of O(1) terms E_f = H : C - 1, so 1e-5 relative).
  const Mat3T<float> dPf = pk1_differential<float>(m, cast<float>(F), MaterialCacheT<float>{cast<float>(cache.a),
                                                                                          static_cast<float>(cache.c)},
                                                   cast<float>(dF));
  REQUIRE(frobenius(cast<double>(dPf) - dP) <= 1e-5 * frobenius(dP));
}

TEST_CASE("hgo: uniaxial tension along and across the fibres matches the closed form", "[material][hgo][analytic]") {
  // The closed form is principal_stresses above (derived there), the lateral stretches those of
  // free lateral faces (solve_lateral). Fibres: one family along e1, or two at +-gamma = 0.6 rad
  // about e1 in the e1-e2 plane. Tension along e1 (along the fibres), along e2 (across them, in
  // their plane) and along e3 (across their plane: they shorten).
  const Variant v = HGO_VARIANTS;
  const double dispersion = GENERATE(0.0, 0.2);
  const double s = GENERATE(1.05, 1.15, 1.3);
  const double gamma = v.families == 2 ? 0.6 : 0.0;
  // The plane vector (1, 1, 0) puts e2 on the y axis: a_k = (cos gamma, +-sin gamma, 0).
  const Material m = ligament(v, dispersion, Vec3{1, 0, 0}, Vec3{1, 1, 0}, gamma);
  double along[3];
  for (int axis = 0; axis < 3; ++axis) {
    double l[3];
    solve_lateral(m, gamma, axis, s, l);
    const Principal closed = principal_stresses(m, gamma, l);
    const double p = closed.tau[axis] / s;
    MaterialCache cache;
    const Mat3 P = first_piola(m, Mat3{{{l[0], 0, 0}, {0, l[1], 0}, {0, 0, l[2]}}}, cache);
    INFO(name(v.formulation) << ", " << v.families << " families, dispersion " << dispersion << ", stretch " << s
                             << " along e" << axis + 1 << ": l = (" << l[0] << ", " << l[1] << ", " << l[2]
                             << "), E " << closed.e << ", P " << P.m[axis][axis] << ", closed form " << p);
    // The closed form and the law evaluate the same quantities in other orders: rounding of a few
    // ulps of the largest term (mu l^2, K ln J, g l^2), 1e-10 relative with ample margin; the
    // lateral stresses vanish up to Newton's last step (their rounding, ~ K eps).
    REQUIRE(P.m[axis][axis] == Approx(p).epsilon(1e-10));
    for (int i = 0; i < 3; ++i) {
      if (i != axis) REQUIRE(std::abs(P.m[i][i]) <= 1e-10 * p);
      // Off the diagonal the two families' terms are exact negatives (their a_k differ in the
      // sign of the e2 component only) and F is diagonal: a few ulps at most.
      for (int c = 0; c < 3; ++c)
        if (c != i) REQUIRE(std::abs(P.m[i][c]) <= 1e-14 * p);
    }
    // Along the fibres they stretch; across their plane they shorten (E < 0 without dispersion)
    // and the ground substance answers alone.
    if (axis == 0) REQUIRE(closed.e > 0);
    if (axis == 2 && dispersion == 0) REQUIRE(closed.e < 0);
    along[axis] = P.m[axis][axis];
  }
  // The fibres make the material stiffer along them than across their plane (k1 = 5 E).
  REQUIRE(along[0] > 1.5 * along[2]);
}

TEST_CASE("hgo: energy, stress and tangent are invariant under rigid motions", "[material][hgo][invariance]") {
  const Variant v = HGO_VARIANTS;
  const Material m = ligament(v, GENERATE(0.0, 0.2), Vec3{0.2, -0.7, 0.4});
  const Mat3 F = state_F(GENERATE(0, 2));
  INFO(name(v.formulation) << ", " << v.families << " families");
  const Mat3 Q = rotation_matrix(quat_exp(Vec3{0.7, -1.9, 2.4}));
  const Mat3 dF = Mat3{{{0.3, -0.2, 0.1}, {0.5, 0.1, -0.4}, {0.2, 0.3, 0.6}}};
  MaterialCache c, cq;
  const Mat3 P = first_piola(m, F, c), Pq = first_piola(m, Q * F, cq);
  // psi(Q F) = psi(F), P(Q F) = Q P(F), dP(Q F)[Q dF] = Q dP(F)[dF]: rounding only (1e-16 per
  // operation on O(1) factors, Q exactly orthogonal to rounding).
  REQUIRE(energy_density(m, Q * F) == Approx(energy_density(m, F)).epsilon(1e-13));
  REQUIRE(frobenius(Pq - Q * P) <= 1e-13 * frobenius(P));
  const Mat3 dP = pk1_differential(m, F, c, dF), dPq = pk1_differential(m, Q * F, cq, Q * dF);
  REQUIRE(frobenius(dPq - Q * dP) <= 1e-13 * frobenius(dP));
  REQUIRE(stress_measures(m, Q * F).fibre_stretch == Approx(stress_measures(m, F).fibre_stretch).epsilon(1e-14));
}

TEST_CASE("hgo: the uncoupled form splits volume change from distortion", "[material][hgo][analytic]") {
  const int families = GENERATE(1, 2);
  const double dispersion = GENERATE(0.0, 0.2);
  const Material m = ligament(Variant{HgoFormulation::uncoupled, families}, dispersion, Vec3{0.8, 0.5, -0.3});
  const double K = m.lambda + 2 * m.mu / 3;
  INFO(families << " families, dispersion " << dispersion);
  // A pure dilatation F = a I leaves every isochoric invariant at rest (E_k = 0: the fibres are
  // slack): P = K ln J F^{-T} = 3 K ln(a) / a I, psi = K/2 (3 ln a)^2. Rounding of E_k near 0
  // (~1e-16) gives the fibres at most k1 * 1e-16: 1e-12 relative.
  for (const double a : {0.9, 1.1}) {
    MaterialCache cache;
    const Mat3 P = first_piola(m, a * identity3(), cache);
    const double p = 3 * K * std::log(a) / a;
    REQUIRE(frobenius(P - p * identity3()) <= 1e-12 * std::abs(p));
    REQUIRE(energy_density(m, a * identity3()) == Approx(0.5 * K * 9 * std::log(a) * std::log(a)).epsilon(1e-12));
  }
  // Where det F = 1 both forms have the same energy: I1bar = I1, I4bar = I4 and the volumetric
  // terms vanish (rounding of det F ~ 1e-16 times lambda: 1e-12 relative).
  Material coupled = m;
  coupled.formulation = HgoFormulation::coupled;
  for (const int k : {0, 2}) {
    const Mat3 F0 = state_F(k);
    const Mat3 F = std::cbrt(1 / det(F0)) * F0;
    REQUIRE(energy_density(m, F) == Approx(energy_density(coupled, F)).epsilon(1e-12));
  }
}

TEST_CASE("hgo: two families at a zero angle are one family of twice the stiffness", "[material][hgo]") {
  // psi_f is linear in k1 and both families coincide: psi, P and dP equal those of one family
  // with 2 k1, to rounding.
  const HgoFormulation formulation = GENERATE(HgoFormulation::coupled, HgoFormulation::uncoupled);
  const Material two = ligament(Variant{formulation, 2}, 0.1, Vec3{0.8, 0.5, -0.3}, Vec3{0, 0, 1}, 0.0);
  const Material one = ligament(Variant{formulation, 1}, 0.1, Vec3{0.8, 0.5, -0.3}, Vec3{0, 0, 1}, 0.0, 1e5);
  const Mat3 F = state_F(0), dF = Mat3{{{0.3, -0.2, 0.1}, {0.5, 0.1, -0.4}, {0.2, 0.3, 0.6}}};
  MaterialCache c1, c2;
  const Mat3 P1 = first_piola(one, F, c1), P2 = first_piola(two, F, c2);
  REQUIRE(energy_density(two, F) == Approx(energy_density(one, F)).epsilon(1e-14));
  REQUIRE(frobenius(P2 - P1) <= 1e-14 * frobenius(P1));
  const Mat3 dP1 = pk1_differential(one, F, c1, dF);
  REQUIRE(frobenius(pk1_differential(two, F, c2, dF) - dP1) <= 1e-14 * frobenius(dP1));
}

TEST_CASE("hgo: rest is free of stress, the fibre stretch is |F a|, invalid parameters are refused", "[material][hgo]") {
  const Material m = ligament(0.1, Vec3{0, 3, 4});
  REQUIRE(m.law == MaterialLaw::hgo);
  REQUIRE(m.formulation == HgoFormulation::coupled);
  REQUIRE(m.fibres.direction.y == Approx(0.6).epsilon(1e-15));  // normalised
  for (const Variant v : {Variant{HgoFormulation::coupled, 1}, Variant{HgoFormulation::coupled, 2},
                          Variant{HgoFormulation::uncoupled, 1}, Variant{HgoFormulation::uncoupled, 2}}) {
    const Material mv = ligament(v, 0.1, Vec3{0, 3, 4});
    MaterialCache cache;
    // The uncoupled ground stress mu/2 (2 F - 2/3 I1 F^{-T}) cancels at rest: a few ulps of mu.
    const double rest = frobenius(first_piola(mv, identity3(), cache));
    INFO(name(v.formulation) << ", " << v.families << " families: |P| at rest " << rest << " Pa");
    REQUIRE(rest <= 1e-14 * mv.mu);
    REQUIRE(energy_density(mv, identity3()) == Approx(0.0).margin(1e-12));
  }
  // Two families: unit axes at +-angle about the direction, in its plane with the plane vector
  // (0.1, 0.3, 0.9); e2 the unit part of that vector orthogonal to e1 = (0, 0.6, 0.8).
  const Material two = ligament(Variant{HgoFormulation::coupled, 2}, 0.1, Vec3{0, 3, 4});
  const Vec3 e1{0, 0.6, 0.8}, p = (1 / std::sqrt(0.91)) * Vec3{0.1, 0.3, 0.9};
  const Vec3 e2 = (1 / norm(p - dot(p, e1) * e1)) * (p - dot(p, e1) * e1);
  for (int k = 0; k < 2; ++k) {
    const Vec3 expected = std::cos(1.0) * e1 + (k == 0 ? 1.0 : -1.0) * std::sin(1.0) * e2;
    REQUIRE(norm(two.fibres.axes[k] - expected) <= 1e-15);
  }
  REQUIRE(norm(with_fibre_direction(two, Vec3{1, 0, 0}).fibres.axes[0] -
               (std::cos(1.0) * Vec3{1, 0, 0} + std::sin(1.0) * (1 / std::sqrt(0.9)) * Vec3{0, 0.3, 0.9})) <= 1e-15);
  // Stretch 1.2 along (0, 0.6, 0.8) by F = I + 0.2 a a: |F a| = 1.2.
  const Vec3 a = m.fibres.direction;
  REQUIRE(stress_measures(m, identity3() + 0.2 * outer(a, a)).fibre_stretch == Approx(1.2).epsilon(1e-14));
  REQUIRE(stress_measures(two, identity3() + 0.2 * outer(a, a)).fibre_stretch == Approx(1.2).epsilon(1e-14));
  REQUIRE(stress_measures(ligament(0, Vec3{1, 0, 0}), identity3()).fibre_stretch == Approx(1.0).epsilon(1e-15));
  REQUIRE(stress_measures(make_material(MaterialLaw::neo_hookean, 1e4, 0.3, 1000), identity3()).fibre_stretch == 0.0);
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{-1, 5, 0, Vec3{1, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 0, 0, Vec3{1, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0.34, Vec3{1, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{0, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{1, 0, 0}, 3}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{1, 0, 0}, 2, 1.6, Vec3{0, 1, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{1, 0, 0}, 2, 0.5, Vec3{0, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{1, 0, 0}, 2, 0.5, Vec3{-2, 0, 0}}));
  REQUIRE_THROWS(with_fibre_direction(two, Vec3{0.1, 0.3, 0.9}));  // along the plane vector
  REQUIRE_NOTHROW(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{1, 0, 0}, 2, 0.5 * 3.14159265358979323846,
                                                           Vec3{0, 1, 0}}));
  REQUIRE(std::string(to_string(MaterialLaw::hgo)) == "hgo");
}
