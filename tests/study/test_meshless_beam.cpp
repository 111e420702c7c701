// The beam study's meshless cantilever in the linear regime, against beam theory.
#include "study/beam_study.hpp"
#include "study/meshless_beam.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

TEST_CASE("meshless MLS cantilever under a small load deflects as a Timoshenko beam", "[study][meshless]") {
  // The study's 16 x 1 x 1 m cantilever with gravity / 1000: tip deflection 7.5 mm = L / 2100,
  // rotations 1e-3 rad, so geometric nonlinearity changes the deflection by O(1e-6) relative.
  BeamSettings s;
  s.gravity = 9.81e-3;
  s.threads = 1;
  const double q = s.mass * s.gravity / s.length;                        // N/m
  const double area = s.width * s.height, inertia = s.width * std::pow(s.height, 3) / 12;
  const double shear = s.young / (2 * (1 + s.poisson)), kappa = 5.0 / 6.0;  // rectangle
  // Timoshenko: bending q L^4 / (8 E I) = 7.534 mm plus shear q L^2 / (2 kappa G A) = 0.031 mm.
  const double expected = q * std::pow(s.length, 4) / (8 * s.young * inertia) +
                          q * s.length * s.length / (2 * kappa * shear * area);
  const BeamResult r = run_beam_case(meshless_beam_case("frame-meshless-mls", 0.5, s), s);
  REQUIRE(r.converged);
  INFO("tip dz " << r.tip_displacement.z << " m, beam theory " << -expected << " m, frames " << r.frames);
  // Margin. At r_f = 0.5 m (two frame layers across the section, 32 along) the measured MLS
  // deflection over Poisson-disk seeds 1, 2, 3 is 1.054, 1.095 and 1.055 times q L^4 / (8 E I),
  // and 0.93 to 0.97 at r_f = 0.7 m: the discretisation error of this resolution is up to 10 %,
  // of either sign. 15 % keeps seed 1 (this case) clear of that scatter, while a missing
  // consistency property fails it (a Shepard kernel at the same spacing gave 1.48 to 1.72 times).
  REQUIRE(std::abs(-r.tip_displacement.z / expected - 1) <= 0.15);
  // The clamp grid on x = 0 holds the end in place: the tip moves along z only, to first order.
  REQUIRE(std::abs(r.tip_displacement.x) <= 1e-3 * expected);
  REQUIRE(std::abs(r.tip_displacement.y) <= 0.05 * expected);
}
