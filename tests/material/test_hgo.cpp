// The fibre-reinforced law (material/hgo.hpp): stress and tangent against finite differences,
// uniaxial tension along and across the fibres against the closed form, rigid-motion invariance,
// the fibre stretch and the refusal of invalid parameters.
#include "core/rotation.hpp"
#include "material/material.hpp"
#include "material/stress_measures.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

namespace {

// Ground substance E = 10 kPa, nu = 0.45; fibres k1 = 50 kPa, k2 = 5 (ligament-like magnitudes).
Material ligament(double dispersion, const Vec3& direction) {
  return make_hgo_material(1e4, 0.45, 1000, Fibres{5e4, 5, dispersion, direction});
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

// Root t of the lateral equilibrium P22(t) = 0 of a uniaxial state, by bisection on [lo, hi] where
// it changes sign (P22 increases with t), to the last bit.
template <class Lateral>
double lateral_root(Lateral p22, double lo, double hi) {
  REQUIRE(p22(lo) < 0);
  REQUIRE(p22(hi) > 0);
  for (int it = 0; it < 200 && hi - lo > 0; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (p22(mid) < 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

TEST_CASE("hgo: P = dpsi/dF and dP = dP/dF by central differences", "[material][hgo][fd]") {
  const double dispersion = GENERATE(0.0, 0.2);
  const int k = GENERATE(0, 1, 2);
  const Material m = ligament(dispersion, Vec3{0.8, 0.5, -0.3});
  const Mat3 F = state_F(k);
  const double e_f = ddot(fibre_structure_tensor<double>(m.fibres), transpose(F) * F) - 1;
  INFO("dispersion " << dispersion << ", state " << k << ", E_f " << e_f);
  // Away from the kink of <E_f> at 0 (the differences below span |dE_f| < 1e-4).
  REQUIRE(std::abs(e_f) > 1e-2);
  MaterialCache cache;
  const Mat3 P = first_piola(m, F, cache);
  // Central differences with h = cbrt(eps) = 6e-6 (tests/support/finite_difference.hpp): truncation
  // h^2 |psi'''| / 6 and round-off eps |psi| / h are both ~1e-10 relative for |F| ~ 1 and the
  // exponential's derivatives of order k2^2 = 25; 1e-6 relative leaves room for those factors and
  // is far below any wrong term (O(1) relative).
  const double h = 6e-6;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      Mat3 Fp = F, Fm = F;
      Fp.m[r][c] += h;
      Fm.m[r][c] -= h;
      const double fd = (energy_density(m, Fp) - energy_density(m, Fm)) / (2 * h);
      REQUIRE(std::abs(fd - P.m[r][c]) <= 1e-6 * frobenius(P));
    }
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
  // Fibres along e1 (structure tensor H = kappa I + (1 - 3 kappa) e1 e1), lambda and mu of the
  // ground substance, F = diag(F11, F22, F33), J = F11 F22 F33. From neo_hookean.hpp and hgo.hpp:
  //   P_ii = mu (F_ii - 1 / F_ii) + lambda ln J / F_ii + 2 g (F H)_ii,
  //   E_f = kappa (tr C - 3) + (1 - 3 kappa)(F11^2 - 1),  g = k1 <E_f> exp(k2 <E_f>^2),
  //   (F H)_11 = F11 (1 - 2 kappa),  (F H)_22 = F22 kappa,  (F H)_33 = F33 kappa.
  // Along the fibres, F = diag(s, t, t) with stretch s: the lateral faces are free, P22 = P33 = 0,
  //   mu (t^2 - 1) + lambda ln(s t^2) + 2 g kappa t^2 = 0              (P22 t = 0)
  // which fixes t (P22 grows with t: bisection, to rounding), and then, eliminating lambda ln J,
  //   P11 = mu (s - t^2 / s) + 2 g (s (1 - 2 kappa) - kappa t^2 / s).
  // Across the fibres, F = diag(t, s, t) stretched along e2: with kappa = 0 the fibres shorten
  // (E_f = t^2 - 1 < 0) and carry nothing, so the ground substance alone answers:
  //   mu (t^2 - 1) + lambda ln(s t^2) = 0,   P22 = mu (s - t^2 / s),   P11 = P33 = 0.
  const double dispersion = GENERATE(0.0, 0.2);
  const double s = GENERATE(1.05, 1.15, 1.3);
  const Material m = ligament(dispersion, Vec3{1, 0, 0});
  const double mu = m.mu, lam = m.lambda, k1 = m.fibres.k1, k2 = m.fibres.k2, kappa = dispersion;
  const auto g_of = [&](double e) { return e > 0 ? k1 * e * std::exp(k2 * e * e) : 0.0; };
  const auto e_along = [&](double t) { return kappa * (s * s + 2 * t * t - 3) + (1 - 3 * kappa) * (s * s - 1); };
  const double t = lateral_root(
      [&](double x) { return mu * (x * x - 1) + lam * std::log(s * x * x) + 2 * g_of(e_along(x)) * kappa * x * x; }, 0.3,
      1.0);
  const double g = g_of(e_along(t));
  const double p11 = mu * (s - t * t / s) + 2 * g * (s * (1 - 2 * kappa) - kappa * t * t / s);
  MaterialCache cache;
  const Mat3 P = first_piola(m, Mat3{{{s, 0, 0}, {0, t, 0}, {0, 0, t}}}, cache);
  INFO("dispersion " << kappa << ", stretch " << s << ", lateral " << t << ", P11 " << P.m[0][0]);
  // The closed form and the law evaluate the same quantities in other orders: rounding of a few
  // ulps of the largest term (mu s, lambda ln J, g s), 1e-10 relative with ample margin; the
  // lateral stress is zero up to the bisection's last bit (|dP22/dt| dt ~ lambda eps).
  REQUIRE(P.m[0][0] == Approx(p11).epsilon(1e-10));
  REQUIRE(std::abs(P.m[1][1]) <= 1e-10 * p11);
  REQUIRE(std::abs(P.m[2][2]) <= 1e-10 * p11);
  REQUIRE(std::abs(P.m[0][1]) + std::abs(P.m[0][2]) + std::abs(P.m[1][2]) == 0.0);

  if (kappa == 0) {
    const double tc =
        lateral_root([&](double x) { return mu * (x * x - 1) + lam * std::log(s * x * x); }, 0.3, 1.0);
    const double p22 = mu * (s - tc * tc / s);
    MaterialCache c2;
    const Mat3 Pc = first_piola(m, Mat3{{{tc, 0, 0}, {0, s, 0}, {0, 0, tc}}}, c2);
    REQUIRE(Pc.m[1][1] == Approx(p22).epsilon(1e-10));
    REQUIRE(std::abs(Pc.m[0][0]) <= 1e-10 * p22);
    REQUIRE(std::abs(Pc.m[2][2]) <= 1e-10 * p22);
    // The fibres make the material stiffer along them than across: k1 = 5 E here.
    REQUIRE(P.m[0][0] > 2 * Pc.m[1][1]);
  }
}

TEST_CASE("hgo: energy, stress and tangent are invariant under rigid motions", "[material][hgo][invariance]") {
  const Material m = ligament(GENERATE(0.0, 0.2), Vec3{0.2, -0.7, 0.4});
  const Mat3 F = state_F(GENERATE(0, 2));
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

TEST_CASE("hgo: rest is free of stress, the fibre stretch is |F a|, invalid parameters are refused", "[material][hgo]") {
  const Material m = ligament(0.1, Vec3{0, 3, 4});
  REQUIRE(m.law == MaterialLaw::hgo);
  REQUIRE(m.fibres.direction.y == Approx(0.6).epsilon(1e-15));  // normalised
  MaterialCache cache;
  REQUIRE(frobenius(first_piola(m, identity3(), cache)) <= 1e-12);
  REQUIRE(energy_density(m, identity3()) == Approx(0.0).margin(1e-12));
  // Stretch 1.2 along (0, 0.6, 0.8) by F = I + 0.2 a a: |F a| = 1.2.
  const Vec3 a = m.fibres.direction;
  REQUIRE(stress_measures(m, identity3() + 0.2 * outer(a, a)).fibre_stretch == Approx(1.2).epsilon(1e-14));
  REQUIRE(stress_measures(ligament(0, Vec3{1, 0, 0}), identity3()).fibre_stretch == Approx(1.0).epsilon(1e-15));
  REQUIRE(stress_measures(make_material(MaterialLaw::neo_hookean, 1e4, 0.3, 1000), identity3()).fibre_stretch == 0.0);
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{-1, 5, 0, Vec3{1, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 0, 0, Vec3{1, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0.34, Vec3{1, 0, 0}}));
  REQUIRE_THROWS(make_hgo_material(1e4, 0.3, 1000, Fibres{5e4, 5, 0, Vec3{0, 0, 0}}));
  REQUIRE(std::string(to_string(MaterialLaw::hgo)) == "hgo");
}
