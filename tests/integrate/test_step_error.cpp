// Adaptive time steps (error estimates of integrate/step_error.hpp, sizes from
// solve/step_controller.hpp): the estimate on free fall (where backward Euler's local error is
// exactly g h^2 / 2), a sudden prescribed motion resolved by rejected and smaller steps, a step
// that cannot converge at min_dt reported with its time, and quasi-static loading of a shipped
// scene against fixed steps, dynamic and static.
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"
#include "integrate/simulation.hpp"
#include "integrate/step_error.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace fascia;

TEST_CASE("adaptive backward Euler on free fall settles at the step whose error is the tolerance", "[integrate][adaptive]") {
  // A free body under gravity with frames as 3-DOF nodes (lumped masses m_i = sum_s w_is rho v_s
  // carry exactly the weights' share of gravity) falls rigidly: backward Euler gives
  // v_{n+1} = v_n + h g exactly, so
  // the estimate (h/2)|v_{n+1} - v_n| = g h^2 / 2 and the accepted steps stay at or below
  // h* = sqrt(2 tol / g). Once accepted the controller proposes 0.9 sqrt(tol / e) h = 0.9 h*.
  Model model = fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::stvk, 2, 1, 1);
  lock_rotations(model);
  ExternalLoads loads;
  const double g = 9.81;
  loads.gravity = Vec3{0, 0, -g};
  SimulationSettings settings;
  settings.dt = 0.1;  // far too large: rejected until the error fits
  settings.newton.tolerance = 1e-10;
  settings.newton.linear.method = LinearMethod::cholmod;
  settings.adaptive.enabled = true;
  settings.adaptive.tolerance = 1e-5;  // m
  settings.adaptive.min_dt = 1e-7;
  Simulation sim(model, loads, settings);
  const double h_star = std::sqrt(2 * settings.adaptive.tolerance / g);
  const double T = 0.05;
  const StepReport r = sim.advance_to(T);
  INFO("accepted " << r.accepted_steps << " rejected " << r.rejected_steps << " last dt " << r.dt);
  REQUIRE(sim.time() == T);
  REQUIRE(r.time == T);
  REQUIRE(r.rejected_steps >= 1);
  REQUIRE(r.accepted_steps >= static_cast<int>(T / h_star));
  REQUIRE(r.accepted_steps == sim.steps_taken());
  REQUIRE(r.dt <= h_star * (1 + 1e-9));
  REQUIRE(sim.controller()->state().dt == Approx(0.9 * h_star).epsilon(1e-6));
  // Position error of backward Euler: x_T = g sum h_k t_k = g T^2 / 2 + g sum h_k^2 / 2, so the
  // drop exceeds g T^2 / 2 by at most tol per accepted step. The Newton tolerance (1e-10 of the
  // weight) adds nothing visible at this scale.
  for (int i = 0; i < model.frame_count(); ++i) {
    const double drop = model.frame_rest_positions[3 * i + 2] - sim.state().positions[3 * i + 2];
    REQUIRE(drop >= 0.5 * g * T * T * (1 - 1e-9));
    REQUIRE(drop - 0.5 * g * T * T <= r.accepted_steps * settings.adaptive.tolerance);
    REQUIRE(sim.state().velocities[6 * i + 2] == Approx(-g * T).epsilon(1e-9));
  }
}

TEST_CASE("adaptive static steps along a straight equilibrium path grow without rejections", "[integrate][adaptive]") {
  // A slab sagging under gravity whose x = 0 face is carried along x at 0.1 m/s (translations
  // prescribed, rotations free) and nothing else holds it: every equilibrium is the first one
  // translated, q*(t) = q*(0) + t v, a straight path. The first two steps have no secant through
  // two equilibria (the first starts from the rest state) and their estimate is the increment:
  // the sag (about 0.2 mm) plus 0.1 m/s x 5 ms, accepted at 1 mm. From the third on it is the
  // distance from the secant, zero up to the Newton tolerance, so the steps grow by 1.8 each
  // (about 6 ms x (1.8^k - 1) / 0.8 reaches 1 s at k = 9) with no rejection, where the increment
  // (<= 1 mm per step) would need at least 100 steps.
  Model model = fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 3, 2, 1);
  PrescribedMotion carry;
  for (int i = 0; i < model.frame_count(); ++i)
    if (model.frame_rest_positions[3 * i] <= 1e-12) carry.frames.push_back(i);
  const Vec3 v{0.1, 0, 0};  // m/s
  carry.velocity = v;
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -0.002};  // m/s^2: a sag of about 0.2 mm (q L^4 / 8EI) of the 10 kPa slab
  SimulationSettings settings;
  settings.integrator = Integrator::static_equilibrium;
  settings.dt = 0.005;
  settings.threads = 1;
  settings.newton.tolerance = 1e-10;
  settings.adaptive.enabled = true;
  settings.adaptive.tolerance = 1e-3;  // m
  settings.adaptive.min_dt = 1e-6;
  Simulation sim(model, loads, settings, {carry});
  const StepReport first = sim.advance_to(0.005);
  REQUIRE(first.accepted_steps == 1);
  REQUIRE(first.rejected_steps == 0);
  const State q0 = sim.state();
  const StepReport r = sim.advance_to(1.0);
  INFO(r.accepted_steps << " accepted, " << r.rejected_steps << " rejected");
  REQUIRE(r.rejected_steps == 0);
  REQUIRE(r.accepted_steps <= 13);  // 1 + 9 growing steps, the last ones evened out to end on 1 s
  // The end is the first equilibrium carried by (1 s - 0.005 s) v. Each
  // equilibrium meets the relative residual 1e-10 of forces of order the slab's weight (2e-3 N),
  // about 2e-13 N against a bending stiffness 3EI/L^3 of about 4 N/m: 1e-13 m, so 1e-8 m bounds
  // the gap with a wide margin.
  double gap = 0;
  for (int i = 0; i < model.frame_count(); ++i)
    gap = std::max(gap, norm(load3(&sim.state().positions[3 * i]) - load3(&q0.positions[3 * i]) - 0.995 * v));
  REQUIRE(gap <= 1e-8);
}

namespace {

// A slab clamped at x = 0 whose far end (x = 0.2 m) is pushed towards the clamp at `speed`.
struct Push {
  Model model;
  std::vector<PrescribedMotion> motions;
};

Push make_push(double speed, double end) {
  Push p;
  p.model = fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 4, 1, 1);
  fix_frames(p.model, [](double x, double, double) { return x <= 1e-12; });
  PrescribedMotion m;
  for (int i = 0; i < p.model.frame_count(); ++i)
    if (p.model.frame_rest_positions[3 * i] >= 0.2 - 1e-12) m.frames.push_back(i);
  m.velocity = Vec3{-speed, 0, 0};
  m.end = end;
  p.motions.push_back(m);
  return p;
}

}  // namespace

TEST_CASE("a sudden push that fails at a fixed dt completes with adaptive steps", "[integrate][adaptive]") {
  // The end moves 80 mm in 20 ms onto 50 mm cells: a fixed step of 20 ms inverts the last cells.
  const Push push = make_push(4.0, 0.02);
  SimulationSettings settings;
  settings.dt = 0.02;
  settings.rayleigh_mass = 1.0;
  {
    Simulation fixed(push.model, ExternalLoads{}, settings, push.motions);
    try {
      fixed.step();
      FAIL("the fixed step converged");
    } catch (const SolverError& e) {
      REQUIRE_THAT(e.what(), Catch::Contains("t = 0.02 s") && Catch::Contains("likely cause") &&
                                 Catch::Contains("inverts"));
    }
    REQUIRE(fixed.steps_taken() == 0);
  }
  settings.adaptive.enabled = true;
  settings.adaptive.tolerance = 1e-3;
  settings.adaptive.min_dt = 1e-6;
  Simulation sim(push.model, ExternalLoads{}, settings, push.motions);
  int rejected = 0, accepted = 0;
  for (int k = 1; k <= 5; ++k) {
    const StepReport r = sim.advance_to(k * settings.dt);
    REQUIRE(r.converged);
    REQUIRE(r.time == k * settings.dt);  // the rows land on the requested times
    rejected += r.rejected_steps;
    accepted += r.accepted_steps;
  }
  REQUIRE(rejected >= 1);
  REQUIRE(accepted > 5);
  // The pushed frames reached the end of their path.
  REQUIRE(sim.state().positions[3 * push.motions[0].frames[0]] == Approx(0.2 - 0.08).epsilon(1e-12));
}

TEST_CASE("a failed variational step names a smaller dt, not the adaptive steps it cannot take", "[integrate]") {
  // The push of the test above at a fixed 20 ms step inverts the last cells under backward Euler,
  // whose potential is evaluated at the step's end. The variational step evaluates it at the
  // midpoint, which a push of 4 m/s leaves admissible (its equations then have a solution); at
  // 8 m/s the midpoint moves the end 80 mm onto the 50 mm cells. solver.adaptive is refused with
  // the variational integrator.
  for (const Integrator integrator : {Integrator::backward_euler, Integrator::variational}) {
    const Push push = make_push(integrator == Integrator::variational ? 8.0 : 4.0, 0.02);
    SimulationSettings settings;
    settings.integrator = integrator;
    settings.dt = 0.02;
    Simulation sim(push.model, ExternalLoads{}, settings, push.motions);
    try {
      sim.step();
      FAIL("the step converged");
    } catch (const SolverError& e) {
      INFO(e.what());
      CHECK_THAT(e.what(), Catch::Contains("likely cause") && Catch::Contains("a smaller solver.dt"));
      const bool names_adaptive = std::string(e.what()).find("solver.adaptive") != std::string::npos;
      CHECK(names_adaptive == (integrator == Integrator::backward_euler));
    }
  }
  const Push push = make_push(4.0, 0.02);
  SimulationSettings adaptive;
  adaptive.integrator = Integrator::variational;
  adaptive.adaptive.enabled = true;
  adaptive.adaptive.min_dt = 1e-6;
  adaptive.adaptive.tolerance = 1e-3;
  REQUIRE_THROWS_WITH(Simulation(push.model, ExternalLoads{}, adaptive, push.motions),
                      Catch::Contains("adaptive time steps need the backward_euler or static integrator"));
}

TEST_CASE("a step that cannot converge at min_dt stops with its time, step and residual", "[integrate][adaptive]") {
  // 10 km/s: even the smallest step (10 us) moves the end by 0.1 m, two cells.
  const Push push = make_push(1e4, 1.0);
  SimulationSettings settings;
  settings.dt = 1e-3;
  settings.adaptive.enabled = true;
  settings.adaptive.tolerance = 1e-3;
  settings.adaptive.min_dt = 1e-5;
  Simulation sim(push.model, ExternalLoads{}, settings, push.motions);
  const State before = sim.state();
  try {
    sim.advance_to(1e-3);
    FAIL("the step converged");
  } catch (const SolverError& e) {
    REQUIRE_THAT(e.what(), Catch::Contains("step 1 (t = 0 s") && Catch::Contains("minimum step 1e-05 s") &&
                               Catch::Contains("relative residual") && Catch::Contains("likely cause"));
  }
  REQUIRE(sim.steps_taken() == 0);
  REQUIRE(sim.time() == 0);
  REQUIRE(sim.state().positions == before.positions);
  // 1e-3 s halved seven times, then min_dt: eight attempts, all rejected.
  REQUIRE(sim.controller()->state().rejected == 8);
}

namespace {

// scenes/quasi_static_press.yaml as `fascia run` builds it (one thread: the same sums every run).
dsl::BuiltScene press_scene(const std::vector<std::string>& overrides = {}) {
  dsl::BuiltScene b =
      dsl::build_scene(dsl::parse_scene(std::string(FASCIA_SOURCE_DIR) + "/scenes/quasi_static_press.yaml", overrides));
  b.settings.threads = 1;
  return b;
}

struct PressRun {
  State state;
  long accepted = 0;
  long attempts = 0;  // accepted and rejected
};

// The run to the scene's duration: fixed steps, or adaptive steps between the output rows
// (multiples of output.every x dt) as `fascia run` drives them.
PressRun run_press(const dsl::BuiltScene& b, bool adaptive, int every) {
  SimulationSettings settings = b.settings;
  settings.adaptive.enabled = adaptive;
  Simulation sim(b.model, b.loads, settings, b.motions);
  PressRun run;
  if (!adaptive) {
    for (int k = 0; k < b.steps; ++k) REQUIRE(sim.step().converged);
    run.accepted = run.attempts = sim.steps_taken();
  } else {
    for (int k = every; k <= b.steps; k += every) {
      const StepReport r = sim.advance_to(k * settings.dt);
      REQUIRE(r.converged);
      run.accepted += r.accepted_steps;
      run.attempts += r.accepted_steps + r.rejected_steps;
    }
  }
  run.state = sim.state();
  return run;
}

// The largest difference of two states' frame positions (m).
double position_gap(const State& a, const State& b) {
  double gap = 0;
  for (size_t k = 0; k < a.positions.size(); ++k) gap = std::max(gap, std::abs(a.positions[k] - b.positions[k]));
  return gap;
}

// Both runs end at the static equilibrium of the pressed block, each to its Newton tolerance:
// |g| <= 1e-8 max(reference force, |g(q_0)|) at the last step, |g(q_0)| below 5 N (the platen's
// largest jump, 4 mm onto a 5 mm cell of 20 x 20 mm² section at E = 40 kPa, is about 3 N); the
// softest stiffness of the pressed block, its lateral bending between the plate and the platen,
// 12 E I / L^3 with I = (20 mm)^4 / 12 and L = 30 mm, is about 240 N/m. So each state lies within
// 5e-8 N / 240 N/m = 2e-10 m of the equilibrium, and two runs within 4e-10 m: kTolerance = 1e-9 m
// leaves a factor 2.5 for the softening of the compressed block. The hold (5.9 s at a mass
// damping of 200 1/s) leaves velocities of 1e-19 m/s (kinetic energies near 1e-40 J): no motion
// remains to add to this.
constexpr double kEquilibriumTolerance = 1e-9;  // m

}  // namespace

// The two quasi-static press cases are tagged [long]: whole runs of scenes/quasi_static_press.yaml,
// most of the suite's time under the sanitizers, which leave them out (tools/test-all,
// docs/fuzzing.md); the step controller's paths run there in the lighter [adaptive] cases.
TEST_CASE("quasi-static press: adaptive backward Euler reaches the fixed steps' equilibrium in 5x fewer steps",
          "[integrate][adaptive][long]") {
  // The platen moves 4 mm per 40 ms step, 5 mm per 50 ms step: at 50 ms the cells next to it
  // invert at the first step, 40 ms is the fixed dt that converges.
  {
    dsl::BuiltScene b = press_scene({"solver.dt=50ms"});
    b.settings.adaptive.enabled = false;
    Simulation sim(b.model, b.loads, b.settings, b.motions);
    REQUIRE_THROWS_AS(sim.step(), SolverError);
  }
  const dsl::BuiltScene b = press_scene();
  REQUIRE(b.settings.integrator == Integrator::backward_euler);
  REQUIRE(b.settings.adaptive.enabled);
  REQUIRE(b.steps == 150);
  const PressRun fixed = run_press(b, false, 25);
  const PressRun adaptive = run_press(b, true, 25);
  INFO("fixed " << fixed.accepted << " steps; adaptive " << adaptive.accepted << " accepted, "
                << adaptive.attempts - adaptive.accepted << " rejected");
  REQUIRE(position_gap(adaptive.state, fixed.state) <= kEquilibriumTolerance);
  // Measured: 22 accepted steps and 7 rejected against 150 (docs/solvers.md). The accepted steps
  // are 5x fewer; the attempts, rejected ones included, at least 4x fewer.
  REQUIRE(5 * adaptive.accepted <= fixed.accepted);
  REQUIRE(4 * adaptive.attempts <= fixed.accepted);
}

TEST_CASE("quasi-static press as static steps: failed increments are halved, easy ones grow", "[integrate][adaptive][long]") {
  // The same load path as a sequence of equilibria (no inertia): a static step also inverts the
  // cells next to the platen when it moves 5 mm at once, and its equilibria are those of the
  // dynamic runs' end.
  const std::vector<std::string> statics = {"solver.integrator=static", "solver.rayleigh_mass=0"};
  {
    std::vector<std::string> o = statics;
    o.push_back("solver.dt=50ms");
    dsl::BuiltScene b = press_scene(o);
    b.settings.adaptive.enabled = false;
    Simulation sim(b.model, b.loads, b.settings, b.motions);
    REQUIRE_THROWS_AS(sim.step(), SolverError);
  }
  const dsl::BuiltScene b = press_scene(statics);
  const PressRun fixed = run_press(b, false, 25);
  const PressRun adaptive = run_press(b, true, 25);
  INFO("fixed " << fixed.accepted << " steps; adaptive " << adaptive.accepted << " accepted, "
                << adaptive.attempts - adaptive.accepted << " rejected");
  // Static steps are equilibria to the Newton tolerance: the bound above holds for each.
  REQUIRE(position_gap(adaptive.state, fixed.state) <= kEquilibriumTolerance);
  const PressRun dynamic = run_press(press_scene(), false, 25);
  REQUIRE(position_gap(dynamic.state, fixed.state) <= kEquilibriumTolerance);
  // The increments' bound (1 mm per step, rotations times the extent) rejects steps on the ramp;
  // on the hold the increments vanish and the steps grow to the output interval.
  REQUIRE(adaptive.attempts > adaptive.accepted);
  REQUIRE(2 * adaptive.attempts <= fixed.accepted);
}
