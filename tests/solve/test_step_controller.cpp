// The step size controller's rules on their own: landing on a target, growth and shrinking by
// the error's order, halving on failure down to min_dt, and the load increments' rule on Newton
// iterations.
#include "solve/step_controller.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

TEST_CASE("the step controller lands on the target, grows easy steps and shrinks rejected ones", "[solve][adaptive]") {
  AdaptiveSettings a;
  a.enabled = true;
  a.tolerance = 1e-3;
  a.min_dt = 1e-4;
  a.max_dt = 0.6;
  StepController c(a, 0.3);
  // 1 s in steps of at most 0.3 s: four equal steps of 0.25 s, no sliver at the end.
  REQUIRE(c.next_step(0.0, 1.0) == Approx(0.25).epsilon(1e-14));
  REQUIRE(c.next_step(0.9, 1.0) == Approx(0.1).epsilon(1e-12));
  // error = tol / 4: factor 0.9 sqrt(4) = 1.8.
  REQUIRE(c.update(0.3, 0.25e-3));
  REQUIRE(c.state().dt == Approx(0.54).epsilon(1e-14));
  // Capped at max_dt.
  REQUIRE(c.update(0.54, 1e-9));
  REQUIRE(c.state().dt == 0.6);
  // error = 4 tol: rejected, factor 0.9 sqrt(1/4) = 0.45.
  REQUIRE_FALSE(c.update(0.5, 4e-3));
  REQUIRE(c.state().dt == Approx(0.225).epsilon(1e-14));
  REQUIRE(c.state().rejected == 1);
  // The first accepted step after a rejection does not grow, the next one does.
  REQUIRE(c.update(0.225, 1e-9));
  REQUIRE(c.state().dt == Approx(0.225).epsilon(1e-14));
  REQUIRE(c.update(0.225, 1e-9));
  REQUIRE(c.state().dt == Approx(0.45).epsilon(1e-14));
  // A failed solve halves the step, down to min_dt; at min_dt there is nothing left to try.
  REQUIRE(c.failed(0.45));
  REQUIRE(c.state().dt == Approx(0.225).epsilon(1e-14));
  REQUIRE(c.failed(2e-4));
  REQUIRE(c.state().dt == a.min_dt);
  REQUIRE_FALSE(c.failed(a.min_dt));
  REQUIRE(c.state().accepted == 4);
  REQUIRE(c.state().rejected == 4);
}

TEST_CASE("the static step controller grows by the increment's first-order rule", "[solve][adaptive]") {
  // Static steps: e = the increment, O(h): factor 0.9 tol / e in [0.2, 2]; e = 0 grows by 1.8.
  AdaptiveSettings a;
  a.enabled = true;
  a.tolerance = 1e-2;
  a.min_dt = 1e-4;
  StepController c(a, 0.1, 1);
  REQUIRE(c.update(0.1, 0.0));
  REQUIRE(c.state().dt == Approx(0.18).epsilon(1e-14));
  REQUIRE(c.update(0.18, 0.5e-2));  // 0.9 * 2
  REQUIRE(c.state().dt == Approx(0.324).epsilon(1e-14));
  REQUIRE_FALSE(c.update(0.324, 3e-2));  // 0.9 / 3 = 0.3
  REQUIRE(c.state().dt == Approx(0.0972).epsilon(1e-12));
}

TEST_CASE("load increments grow by the share of the Newton budget they used", "[solve][adaptive]") {
  // newton_load_stepping: tolerance 1, error = iterations / budget, order 2:
  // h * clamp(0.9 sqrt(budget / iterations), 0.2, 2), every converged increment accepted.
  AdaptiveSettings a;
  a.tolerance = 1.0;
  a.min_dt = 1.0 / 8;  // the first increment halved twice
  StepController c(a, 0.5, 2);
  REQUIRE(c.next_step(0.0, 1.0) == 0.5);
  // 5 of 50 iterations: 0.9 sqrt(10) = 2.85, capped at 2.
  REQUIRE(c.update(0.5, 5.0 / 50));
  REQUIRE(c.state().dt == 1.0);
  // 45 of 50: 0.9 sqrt(50 / 45) = 0.949: the next increment shrinks before it fails.
  REQUIRE(c.update(1.0, 45.0 / 50));
  REQUIRE(c.state().dt == Approx(0.9 * std::sqrt(50.0 / 45)).epsilon(1e-14));
  // Failures halve, down to the first / 4; the increment after a failure does not grow.
  REQUIRE(c.failed(0.5));
  REQUIRE(c.failed(0.25));
  REQUIRE(c.state().dt == 0.125);
  REQUIRE_FALSE(c.failed(0.125));
  REQUIRE(c.update(0.125, 1.0 / 50));
  REQUIRE(c.state().dt == 0.125);
  REQUIRE(c.update(0.125, 1.0 / 50));
  REQUIRE(c.state().dt == 0.25);
}
