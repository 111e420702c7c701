// KINSOL as the nonlinear solver of a step (solve/kinsol_solver.hpp): the same equilibrium and the
// same backward-Euler step as the engine's Newton within the Newton tolerance, the variational
// step's equations solved to it, and failures reported without a non-finite state.
#include "integrate/simulation.hpp"
#include "integrate/step_potential.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/fixtures.hpp"
#include "support/minimiser_bound.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

namespace {

bool finite(const State& s) {
  for (const std::vector<double>* v : {&s.positions, &s.orientations, &s.velocities})
    for (double x : *v)
      if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

// Both runs stop where |g_free| <= tau F; support/minimiser_bound.hpp turns the two gradients into
// a bound on the distance between the states (|g_free| / lambda_min each, factor 2 for the
// Hessian's variation), measured by one CPU potential. The cantilever bends under a gravity
// large enough to turn its tip frames by about 0.1 rad, so the chart's rotation increments
// (T(theta) = J_l(theta_r)) matter; the coupled scene carries a rigid plate whose attached frames
// follow it through the retraction.
TEST_CASE("KINSOL reaches the Newton's equilibrium and backward-Euler step within the Newton tolerance",
          "[solve][kinsol]") {
  const Integrator integrator = GENERATE(Integrator::static_equilibrium, Integrator::backward_euler);
  const bool coupled = GENERATE(false, true);
  const LinearMethod method = GENERATE(LinearMethod::pcg, LinearMethod::cholmod);
  INFO(to_string(integrator) << ", coupled " << coupled << ", " << to_string(method));
  Model model = coupled ? fascia::test::coupled_model(CellType::tetrahedron, true)
                        : fascia::test::small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 4, 1, 1);
  if (!coupled) fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, coupled ? -9.81 : -60.0};
  SimulationSettings settings;
  settings.integrator = integrator;
  settings.dt = 0.01;
  settings.threads = 1;
  settings.newton.tolerance = 1e-9;
  settings.newton.linear.method = method;
  settings.newton.linear.tolerance = 1e-10;
  SimulationSettings kinsol_settings = settings;
  kinsol_settings.newton.nonlinear = NonlinearSolver::kinsol;
  Simulation newton(model, loads, settings), kinsol(model, loads, kinsol_settings);
  const StepReport a = newton.step(), b = kinsol.step();
  REQUIRE(a.converged);
  REQUIRE(b.converged);
  CHECK(b.residual <= settings.newton.tolerance);
  CHECK(b.newton_iterations > 0);
  if (method == LinearMethod::pcg) CHECK(b.cg_iterations > 0);

  StepPotential probe(newton.model(), newton.loads(), 1);
  if (integrator == Integrator::static_equilibrium)
    probe.set_static();
  else
    probe.set_dynamic(rest_state(newton.model()), settings.dt, 0, 0);
  const fascia::test::MinimiserBound bound = fascia::test::minimiser_bound(probe, newton.state(), kinsol.state());
  REQUIRE(bound.lambda_min > 0);
  const double distance = (1 + bound.extent) * bound.distance + 1e-15;  // + a few ulps of 0.1 m
  const fascia::test::StateDifference d = fascia::test::max_difference(newton.state(), kinsol.state());
  INFO("position difference " << d.position << " m, rotation " << d.rotation << " rad, bound " << distance);
  CHECK(d.position <= distance);
  CHECK(d.rotation <= distance);
  CHECK(distance < 1e-6);  // the bound is tight enough to say something
  // The comparison is not vacuous: the step moved the frames and turned them.
  const fascia::test::StateDifference moved = fascia::test::max_difference(rest_state(newton.model()), newton.state());
  CHECK(moved.position > 1e3 * distance);
  if (!coupled && integrator == Integrator::static_equilibrium) CHECK(moved.rotation > 0.05);
}

// The variational step has no potential: KINSOL solves its discrete Euler-Lagrange equations (4)
// to the relative tolerance, which the step's own residual confirms, and the step keeps linear
// momentum as the Newton's does (variational_step.hpp: |J change| <= |r| per step).
TEST_CASE("KINSOL solves the variational step to the Newton tolerance", "[solve][kinsol]") {
  const Model model = fascia::test::small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 3, 2, 2);
  SimulationSettings settings;
  settings.integrator = Integrator::variational;
  settings.dt = 0.005;
  settings.newton.tolerance = 1e-10;
  settings.newton.nonlinear = NonlinearSolver::kinsol;
  settings.newton.linear.method = LinearMethod::cholmod;
  Simulation sim(model, ExternalLoads{}, settings);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double& v : sim.state().velocities) v = 0.3 * u(rng);  // deforming, spinning start
  auto momentum = [&] {
    Vec3 p{0, 0, 0};
    for (int i = 0; i < model.frame_count(); ++i) p += model.frame_masses[i] * load3(&sim.state().velocities[6 * i]);
    return p;
  };
  double speed = 0;
  for (int i = 0; i < model.frame_count(); ++i) speed += model.frame_masses[i] * norm(load3(&sim.state().velocities[6 * i]));
  const Vec3 p0 = momentum();
  for (int k = 0; k < 5; ++k) {
    const StepReport r = sim.step();
    REQUIRE(r.converged);
    CHECK(r.residual <= settings.newton.tolerance);
    CHECK(r.newton_iterations >= 1);
  }
  // Each step's residual |r| <= tau max(F, |p|/h) h changes the momentum by at most that, five
  // steps; 1e-8 of the momentum scale covers 5 tau (1 + round-off).
  CHECK(norm(momentum() - p0) <= 1e-8 * speed);
}

// A failing solve: the absurd load of test_simulation.cpp's failure test with two iterations.
// KINSOL's return flag is named, the state keeps the last step and nothing non-finite appears.
TEST_CASE("a KINSOL solve that fails reports why and leaves the state finite", "[solve][kinsol]") {
  const Integrator integrator = GENERATE(Integrator::backward_euler, Integrator::static_equilibrium);
  Model model = fascia::test::small_box_model(CellType::tetrahedron, MaterialLaw::stvk);
  fix_frames(model, [](double x, double, double) { return x <= 1e-12; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81e6};
  SimulationSettings settings;
  settings.integrator = integrator;
  settings.dt = 1.0;
  settings.max_load_halvings = 1;
  settings.newton.max_iterations = 2;
  settings.newton.nonlinear = NonlinearSolver::kinsol;
  Simulation sim(model, loads, settings);
  const State before = sim.state();
  try {
    sim.step();
    FAIL("the step was accepted");
  } catch (const SolverError& e) {
    INFO(e.what());
    CHECK_THAT(e.what(), Catch::Contains("KINSOL did not converge") && Catch::Contains("KIN_"));
  }
  CHECK(sim.state().positions == before.positions);
  CHECK(sim.state().orientations == before.orientations);
  CHECK(finite(sim.state()));
  CHECK(sim.steps_taken() == 0);
}

TEST_CASE("solver.nonlinear names its solvers", "[solve][kinsol]") {
  CHECK(parse_nonlinear_solver("newton") == NonlinearSolver::newton);
  CHECK(parse_nonlinear_solver("kinsol") == NonlinearSolver::kinsol);
  CHECK(std::string(to_string(NonlinearSolver::kinsol)) == "kinsol");
  CHECK_THROWS_AS(parse_nonlinear_solver("KINSOL"), std::invalid_argument);
}
