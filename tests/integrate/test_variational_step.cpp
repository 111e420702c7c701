// The variational step (integrate/variational_step.hpp): derivatives of the discrete action
// against finite differences, exact momentum conservation of a free coupled system (tissue, shell
// and rigid body sharing frames), bounded energy, and the Simulation wiring.
#include "integrate/variational_step.hpp"

#include "core/rotation.hpp"
#include "integrate/discrete_action.hpp"
#include "dsl/build_scene.hpp"
#include "integrate/simulation.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/finite_difference.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <iostream>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("left Jacobian of SO(3): exp(phi + e) = exp(J_l(phi) e) exp(phi) and inverse", "[integrate][variational]") {
  const Vec3 phi = GENERATE(Vec3{1e-5, -2e-5, 3e-6}, Vec3{0.3, -0.2, 0.5}, Vec3{1.5, 0.7, -1.9});
  const Mat3 J = left_jacobian(phi);
  // J_l J_l^{-1} = I: both closed forms agree to round-off (entries O(1)).
  const Mat3 P = J * inverse_left_jacobian(phi);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) REQUIRE(P.m[r][c] == Approx(r == c ? 1.0 : 0.0).margin(1e-13));
  // Central difference of log(exp(phi + t e) exp(-phi)) at t = 0 is J_l(phi) e; step 1e-5 gives a
  // truncation error ~ t^2 |third derivative| ~ 1e-10 and round-off ~ eps / t ~ 2e-11.
  for (int k = 0; k < 3; ++k) {
    Vec3 e{0, 0, 0};
    (k == 0 ? e.x : k == 1 ? e.y : e.z) = 1.0;
    const double t = 1e-5;
    const Quat back = conjugate(quat_exp(phi));
    const Vec3 fd = (0.5 / t) * (quat_log(quat_exp(phi + t * e) * back) - quat_log(quat_exp(phi - t * e) * back));
    const Vec3 column = J * e;
    REQUIRE(norm(fd - column) <= 1e-8);
  }
}

TEST_CASE("variational step: -D1 S and D2 S match finite differences of the discrete action", "[integrate][variational][fd]") {
  const Model model = coupled_model();
  ExternalLoads loads;
  loads.gravity = Vec3{0.5, -9.81, 2.0};
  StepPotential potential(model, loads);
  const RigidMapping& mapping = potential.rigid_mapping();
  const double dt = GENERATE(0.01, 0.002);
  VariationalStep step(model, potential, dt);
  State start = random_state(model, 31, 0.005, 0.5, 2.0);
  mapping.sync(start);
  // End: a finite step from the start with relative rotations up to 0.3 rad, so that the
  // midpoint's Jacobians A and B of (3) differ clearly from I/2.
  State end = perturbed(model, start, random_direction(model, 7, 0.01), 0.3);
  mapping.sync(end);
  std::vector<double> minus_d1, d2;
  step.action_derivatives(start, end, minus_d1, d2);
  const double scale = std::max(norm(minus_d1), norm(d2));
  const Energy of_start = [&](const State& s) {
    State t = s;
    mapping.sync(t);
    return step.action(t, end);
  };
  const Energy of_end = [&](const State& s) {
    State t = s;
    mapping.sync(t);
    return step.action(start, t);
  };
  for (int k = 0; k < model.dof_count(); ++k) {
    if (model.rigid_parents[k / 6] >= 0) {
      REQUIRE(minus_d1[k] == 0);
      REQUIRE(d2[k] == 0);
      continue;
    }
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = 1.0;
    // Harness step and tolerance (support/finite_difference.hpp): 1e-6 of the derivative's norm.
    const double fd1 = directional_derivative(model, of_start, start, e);
    const double fd2 = directional_derivative(model, of_end, end, e);
    INFO("dof " << k << ": -D1 " << minus_d1[k] << " fd " << -fd1 << ", D2 " << d2[k] << " fd " << fd2);
    REQUIRE(std::abs(-fd1 - minus_d1[k]) <= 1e-6 * scale);
    REQUIRE(std::abs(fd2 - d2[k]) <= 1e-6 * scale);
  }
}

TEST_CASE("variational step: the iteration matrix is the residual's Jacobian where the omitted terms vanish",
          "[integrate][variational][fd]") {
  // Start at rest, end rigidly translated: no relative rotation (F = I, psi = 0, so A = B = I/2
  // and the kinetic Jacobian is symmetric), no stress at the midpoint (tau = 0), and the same
  // rigid-mapping offsets at both ends. There every term the matrix omits (variational_step.hpp)
  // is zero, and 4 H d must equal the derivative of 4 r / h along d.
  const Model model = coupled_model();
  const ExternalLoads no_loads;
  StepPotential potential(model, no_loads);
  const RigidMapping& mapping = potential.rigid_mapping();
  const double dt = 0.01;
  VariationalStep step(model, potential, dt);
  State start = rest_state(model);
  mapping.sync(start);
  State end = start;
  for (int i = 0; i < model.frame_count(); ++i) store3(&end.positions[3 * i], load3(&end.positions[3 * i]) + Vec3{0.002, -0.001, 0.003});
  std::vector<double> p_start(model.dof_count(), 0.0), r;
  const LinearSystem H4 = step.iteration_matrix(start, end);
  std::vector<double> d = random_direction(model, 11, 0.01);
  for (int k = 0; k < model.dof_count(); ++k)
    if (H4.fixed[k]) d[k] = 0;
  std::vector<double> hd(model.dof_count());
  H4.apply(d.data(), hd.data());
  // Central difference of r along d (the residual is a gradient-like first derivative: harness
  // step 6e-6, error ~ eps^(2/3) relative; 1e-6 of |4 H d| leaves the usual margin).
  auto residual_at = [&](double t) {
    State e = perturbed(model, end, d, t);
    mapping.sync(e);
    std::vector<double> out;
    step.residual(start, e, p_start, out);
    return out;
  };
  const double t = 6e-6;
  const std::vector<double> plus = residual_at(t), minus = residual_at(-t);
  for (int k = 0; k < model.dof_count(); ++k) {
    if (H4.fixed[k]) continue;
    const double fd = 4 / dt * (plus[k] - minus[k]) / (2 * t);
    INFO("dof " << k << ": 4Hd " << hd[k] << " fd " << fd);
    REQUIRE(std::abs(fd - hd[k]) <= 1e-6 * norm(hd));
  }
}

TEST_CASE("variational step: a free coupled system conserves linear and angular momentum", "[integrate][variational][coupling]") {
  const Model model = coupled_model();
  const ExternalLoads no_loads;  // no gravity, nothing fixed, no damping
  StepPotential potential(model, no_loads);
  const double dt = 0.005;
  VariationalStep step(model, potential, dt);
  NewtonSettings newton;
  newton.tolerance = 1e-10;
  newton.linear.method = LinearMethod::cholmod;

  State state = moving_start(model, potential.rigid_mapping());
  const Momentum p0 = momentum(model, state);
  const double e0 = kinetic_energy(model, state) + potential.elastic_energy(state);
  int reduced = 0;
  for (int i = 0; i < model.frame_count(); ++i) reduced += model.rigid_parents[i] < 0;
  const int steps = 200;
  double max_p = 0, max_l = 0, bound_p = 0, bound_l = 0, e_min = e0, e_max = e0;
  int iterations = 0;
  Momentum previous = p0;
  for (int n = 0; n < steps; ++n) {
    State next = state;
    const NewtonResult r = step.advance(state, next, newton, 0.0);
    REQUIRE(r.converged());
    iterations += r.iterations;
    // Discrete Noether (variational_step.hpp): J(q_{k+1}, p_{k+1}) = J(q_k, p_k + r) with r the
    // residual left in (4), so per step |dP| <= sum |r_x| <= sqrt(n) |r| and
    // |dL| <= sum (|x_i| |r_x,i| + |r_r,i|) <= (sqrt(sum |x_i|^2) + sqrt(n) 1 m) |r|,
    // plus the round-off of the sums (ε = 1.1e-16 times a few hundred terms: 1e-13 of the momenta).
    REQUIRE(step.residual_norm() <= newton.tolerance * step.residual_scale() * dt);
    double sum_x2 = 0;
    for (int i = 0; i < model.frame_count(); ++i)
      if (model.rigid_parents[i] < 0) sum_x2 += dot(load3(&state.positions[3 * i]), load3(&state.positions[3 * i]));
    const Momentum p = momentum(model, next);
    const double rn = step.residual_norm();
    const double roundoff = 1e-13 * (norm(p0.linear) + norm(p0.angular) + step.residual_scale() * dt);
    const double step_p = std::sqrt(double(reduced)) * rn + roundoff;
    const double step_l = (std::sqrt(sum_x2) + std::sqrt(double(reduced))) * rn + roundoff;
    REQUIRE(norm(p.linear - previous.linear) <= step_p);
    REQUIRE(norm(p.angular - previous.angular) <= step_l);
    bound_p += step_p;
    bound_l += step_l;
    previous = p;
    max_p = std::max(max_p, norm(p.linear - p0.linear) / norm(p0.linear));
    max_l = std::max(max_l, norm(p.angular - p0.angular) / norm(p0.angular));
    const double e = kinetic_energy(model, next) + potential.elastic_energy(next);
    e_min = std::min(e_min, e);
    e_max = std::max(e_max, e);
    state = std::move(next);
  }
  // Energy: a variational integrator keeps it oscillating within O((h w)^2) of E0 instead of
  // drifting (Marsden & West §1.4, backward error analysis). Measured here: within 1e-5 of E0;
  // the bound 1e-4 leaves a decade, while backward Euler with the same step loses 0.4 % of E0
  // in its first 20 steps (tests/integrate/test_coupling.cpp prints it).
  REQUIRE(e_max - e_min <= 1e-4 * e0);
  // Over the whole run the drift stays within the sum of the per-step bounds.
  REQUIRE(max_p * norm(p0.linear) <= bound_p);
  REQUIRE(max_l * norm(p0.angular) <= bound_l);
  std::cout << "free coupled system, " << steps << " variational steps of " << dt * 1e3
            << " ms: max relative drift of linear momentum " << max_p << ", angular momentum " << max_l
            << " (bounds " << bound_p / norm(p0.linear) << ", " << bound_l / norm(p0.angular) << "); energy in [" << e_min / e0 << ", " << e_max / e0 << "] x E0; " << iterations << " iterations\n";
}

TEST_CASE("variational integrator in Simulation: same trajectory as the step, momenta kept, damping refused", "[integrate][variational]") {
  REQUIRE(parse_integrator("variational") == Integrator::variational);
  REQUIRE(std::string(to_string(Integrator::variational)) == "variational");
  const Model model = coupled_model();
  SimulationSettings settings;
  settings.integrator = Integrator::variational;
  settings.dt = 0.005;
  settings.newton.tolerance = 1e-10;
  settings.newton.linear.method = LinearMethod::cholmod;
  Simulation sim(model, ExternalLoads{}, settings);
  StepPotential potential(sim.model(), sim.loads());
  sim.state() = moving_start(sim.model(), potential.rigid_mapping());
  VariationalStep step(sim.model(), potential, settings.dt);
  State state = sim.state();
  for (int n = 0; n < 5; ++n) {
    sim.step();
    State next = state;
    REQUIRE(step.advance(state, next, settings.newton, 0.0).converged());
    state = std::move(next);
  }
  // Same operations in the same order: equal to round-off of the thread-parallel sums.
  for (size_t k = 0; k < state.positions.size(); ++k) REQUIRE(sim.state().positions[k] == Approx(state.positions[k]).margin(1e-14));
  for (size_t k = 0; k < state.velocities.size(); ++k) REQUIRE(sim.state().velocities[k] == Approx(state.velocities[k]).margin(1e-10));

  settings.rayleigh_mass = 1.0;
  REQUIRE_THROWS_WITH(Simulation(model, ExternalLoads{}, settings), Catch::Contains("no Rayleigh damping"));
}

TEST_CASE("variational integrator at twice the coupling scene's dt: Newton-Krylov where the iteration matrix's directions fail",
          "[integrate][variational]") {
  // scenes/coupling.yaml undamped at 20 ms steps: at step 4 the symmetric iteration matrix's
  // directions stop decreasing |r| at a relative residual of 5e-5 (their line search fails), and
  // Newton continues along Newton-Krylov directions (solve/newton.hpp) to the tolerance.
  dsl::BuiltScene b = dsl::build_scene(dsl::parse_scene(
      std::string(FASCIA_SOURCE_DIR) + "/scenes/coupling.yaml",
      {"solver.integrator=variational", "solver.rayleigh_mass=0", "solver.dt=20ms", "run.duration=0.1s"}));
  b.settings.threads = 1;
  Simulation sim(b.model, b.loads, b.settings, b.motions);
  REQUIRE(b.steps == 5);
  double e0 = 0;
  for (int k = 1; k <= b.steps; ++k) {
    const StepReport r = sim.step();
    INFO("step " << k << ": " << r.message);
    REQUIRE(r.converged);
    REQUIRE(r.residual <= b.settings.newton.tolerance);
    const double e = r.kinetic_energy + r.elastic_energy + r.external_potential;
    if (k == 1) e0 = e;
    std::cout << "coupling.yaml, variational, 20 ms: step " << k << " Newton " << r.newton_iterations << " CG "
              << r.cg_iterations << ", energy " << e << " J (step 1: " << e0 << ")\n";
  }
}
