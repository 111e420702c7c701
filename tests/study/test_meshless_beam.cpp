// The beam study's meshless cantilever in the linear regime, against beam theory.
#include "study/beam_study.hpp"
#include "study/meshless_beam.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

using namespace fascia;

// Tagged [long]: four seeds of a full beam case, about a minute of a Release build; left out of the
// run under the sanitizers (tools/test-all, docs/fuzzing.md), where the [meshless] cases remain.
TEST_CASE("meshless MLS cantilever under a small load deflects as a Timoshenko beam, whatever the seed",
          "[study][meshless][long]") {
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
  double lowest = 1e300, highest = 0;
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    s.seed = seed;
    const BeamResult r = run_beam_case(meshless_beam_case("frame-meshless-mls", 0.5, s), s);
    REQUIRE(r.converged);
    const double ratio = -r.tip_displacement.z / expected;
    INFO("seed " << seed << ": tip " << r.tip_displacement.x << ", " << r.tip_displacement.y << ", "
                 << r.tip_displacement.z << " m, beam theory " << -expected << " m, frames " << r.frames);
    // At r_f = 0.5 m (two frame layers across the section, 32 along) the measured MLS deflection
    // over seeds 1-5 is 0.957 to 0.971 times beam theory: the discretisation is stiff by 3-4 %.
    // [0.92, 1.01] keeps that clear, allows the 3D clamp's own few tenths of a per cent, and fails
    // a missing consistency property (a Shepard kernel at this spacing gave 1.48 to 1.72 times).
    REQUIRE(ratio >= 0.92);
    REQUIRE(ratio <= 1.01);
    // The clamp grid on x = 0 holds the end in place: the tip moves along z only, to first order.
    // Lateral: measured |dy| <= 0.0031 |dz| over seeds 1-5; a symmetric problem, so 0.01 (three
    // times that) flags a seed-dependent sideways bending (0.028 with Poisson frames up to r_f / 2
    // from the clamp frames).
    REQUIRE(std::abs(r.tip_displacement.x) <= 1e-3 * expected);
    REQUIRE(std::abs(r.tip_displacement.y) <= 0.01 * expected);
    lowest = std::min(lowest, ratio), highest = std::max(highest, ratio);
  }
  // Seed independence: the measured range over seeds 1-5 is 1.4 % (0.957 to 0.971). 2.5 % is 1.8
  // times that; Poisson frames allowed within r_f / 2 of the clamp frames gave 5.3 % over seeds
  // 1-4 (0.973 to 1.026: a frame just inside the clamped face lets the face move around it).
  INFO("deflection / beam theory over seeds 1-4: " << lowest << " to " << highest);
  REQUIRE(highest - lowest <= 0.025);
}
