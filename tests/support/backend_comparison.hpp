// Two Simulations of one scene, the CPU elasticity and another backend (ElasticityFactory),
// stepped in lockstep: before each step the second starts from the first's state, so every step
// is compared from an identical start and differences do not accumulate. Each step's end states
// must agree within the a-posteriori bound of support/minimiser_bound.hpp.
#pragma once

#include "integrate/simulation.hpp"
#include "support/minimiser_bound.hpp"

#include <catch2/catch.hpp>

#include <cfloat>
#include <cstdio>

namespace fascia::test {

// Round-off floor of a state of coordinates up to `scale` (m): a few ulps, for states whose
// gradients vanish to round-off (the bound is then itself at round-off level).
inline double state_round_off(double scale) { return 8 * DBL_EPSILON * (1 + scale); }

inline double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// Runs `steps` steps of the scene on both backends and checks every step. Returns the largest
// ratio of a measured difference to its bound (printed per step).
// `other_settings` are the settings of the backend under test (its elasticity and step backend);
// the CPU run uses `settings` with neither.
inline double check_backends_agree(const char* label, const Model& model, const ExternalLoads& loads,
                                   const SimulationSettings& settings, const SimulationSettings& other_settings,
                                   int steps, const std::vector<PrescribedMotion>& motions = {}) {
  SimulationSettings cpu_settings = settings;
  cpu_settings.elasticity = {};
  cpu_settings.step_backend = {};
  Simulation cpu(model, loads, cpu_settings, motions), other(model, loads, other_settings, motions);
  StepPotential probe(cpu.model(), cpu.loads(), settings.threads);
  const bool dynamic = settings.integrator == Integrator::backward_euler;
  double worst = 0;
  for (int k = 1; k <= steps; ++k) {
    const State start = cpu.state();
    other.state() = start;
    const StepReport rc = cpu.step();
    const StepReport ro = other.step();
    if (dynamic)
      probe.set_dynamic(start, settings.dt, settings.rayleigh_mass, settings.rayleigh_stiffness);
    else
      probe.set_equilibrium();  // the static solve's potential (with the frame-hex stabilisation)
    const MinimiserBound b = minimiser_bound(probe, cpu.state(), other.state());
    const StateDifference d = max_difference(other.state(), cpu.state());
    const double floor = state_round_off(max_abs(cpu.state().positions));
    // Positions: |dx_i| <= (1 + extent) |dq| (mapped frames, see minimiser_bound.hpp);
    // rotations |dr_i| <= |dq|; velocities Delta / h from the same start: the same over h.
    const double lever = 1 + b.extent;
    const double bound_x = lever * b.distance + floor, bound_r = b.distance + floor;
    const double bound_v = dynamic ? (lever * b.distance + floor) / settings.dt : 0.0;
    std::printf("[%s] step %d: newton %d/%d cg %d/%d |g| %.2e/%.2e lambda_min %.3e | position %.2e (bound %.2e) "
                "rotation %.2e (bound %.2e) velocity %.2e (bound %.2e)\n",
                label, k, rc.newton_iterations, ro.newton_iterations, rc.cg_iterations, ro.cg_iterations, b.gradient_a,
                b.gradient_b, b.lambda_min, d.position, bound_x, d.rotation, bound_r, d.velocity, bound_v);
    REQUIRE(b.lambda_min > 0);
    CHECK(d.position <= bound_x);
    CHECK(d.rotation <= bound_r);
    if (dynamic)
      CHECK(d.velocity <= bound_v);
    else
      CHECK(d.velocity == 0.0);  // static steps end at rest on both backends
    worst = std::max({worst, d.position / bound_x, d.rotation / bound_r, dynamic ? d.velocity / bound_v : 0.0});
  }
  return worst;
}

inline double check_backends_agree(const char* label, const Model& model, const ExternalLoads& loads,
                                   const SimulationSettings& settings, const ElasticityFactory& backend, int steps) {
  SimulationSettings other_settings = settings;
  other_settings.elasticity = backend;
  return check_backends_agree(label, model, loads, settings, other_settings, steps);
}

}  // namespace fascia::test
