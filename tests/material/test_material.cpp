// Stress = derivative of the energy density, differential = derivative of the stress, and the
// StVK uniaxial analytic case.
#include "material/material.hpp"

#include <catch2/catch.hpp>

using namespace fascia;

namespace {

Mat3 sample_F() { return Mat3{{{1.1, 0.2, -0.05}, {0.03, 0.9, 0.1}, {-0.1, 0.05, 1.2}}}; }

}  // namespace

TEST_CASE("P = dpsi/dF and dP = dP/dF by central differences", "[material][fd]") {
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const Material m = make_material(law, 1e4, 0.3, 1000);
  const Mat3 F = sample_F();
  MaterialCache cache;
  const Mat3 P = first_piola(m, F, cache);
  const Mat3 dF = Mat3{{{0.3, -0.2, 0.1}, {0.5, 0.1, -0.4}, {0.2, 0.3, 0.6}}};
  const Mat3 dP = pk1_differential(m, F, cache, dF);
  const double h = 6e-6;  // cbrt(eps): see tests/support/finite_difference.hpp
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      Mat3 Fp = F, Fm = F;
      Fp.m[r][c] += h;
      Fm.m[r][c] -= h;
      const double fd = (energy_density(m, Fp) - energy_density(m, Fm)) / (2 * h);
      REQUIRE(std::abs(fd - P.m[r][c]) <= 1e-6 * std::sqrt(ddot(P, P)));
    }
  MaterialCache cp, cm;
  const Mat3 Pp = first_piola(m, F + h * dF, cp), Pm = first_piola(m, F - h * dF, cm);
  const Mat3 fd = (1 / (2 * h)) * (Pp - Pm);
  REQUIRE(std::sqrt(ddot(fd - dP, fd - dP)) <= 1e-6 * std::sqrt(ddot(dP, dP)));
}

TEST_CASE("rest state is stress free and energy free", "[material]") {
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const Material m = make_material(law, 1e4, 0.3, 1000);
  MaterialCache cache;
  const Mat3 P = first_piola(m, identity3(), cache);
  REQUIRE(ddot(P, P) <= 1e-24);
  REQUIRE(energy_density(m, identity3()) == Approx(0.0).margin(1e-12));
}

TEST_CASE("StVK uniaxial stress: S11 = E E11 with lateral Green strains -nu E11", "[material][analytic]") {
  const double E = 4e4, nu = 0.3;
  const Material m = make_material(MaterialLaw::stvk, E, nu, 1000);
  const double stretch = 1.3;
  const double e11 = 0.5 * (stretch * stretch - 1);
  const double lateral = std::sqrt(1 - 2 * nu * e11);  // E22 = E33 = -nu E11
  const Mat3 F = Mat3{{{stretch, 0, 0}, {0, lateral, 0}, {0, 0, lateral}}};
  const Mat3 S = stvk_second_piola(m.lambda, m.mu, F);
  REQUIRE(S.m[0][0] == Approx(E * e11).epsilon(1e-13));
  REQUIRE(std::abs(S.m[1][1]) <= 1e-10 * E);
  REQUIRE(std::abs(S.m[2][2]) <= 1e-10 * E);
}

TEST_CASE("neo-Hookean rejects inversion; invalid parameters are refused", "[material]") {
  const Material m = make_material(MaterialLaw::neo_hookean, 1e4, 0.3, 1000);
  const Mat3 inverted = Mat3{{{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  REQUIRE(std::isinf(energy_density(m, inverted)));
  REQUIRE_THROWS(make_material(MaterialLaw::stvk, -1.0, 0.3, 1000));
  REQUIRE_THROWS(make_material(MaterialLaw::stvk, 1e4, 0.5, 1000));
  REQUIRE_THROWS(make_material(MaterialLaw::stvk, 1e4, -1.0, 1000));
}
