// A coupled system (paper §4.2): a tissue block sharing its top frames with a shell and with its
// bottom frames attached to a rigid body. Finite-difference checks of the reduced potential
// (rigid mapping), momentum conservation of the free system, dissipation with damping.
#include "core/rotation.hpp"
#include "integrate/simulation.hpp"
#include "integrate/step_potential.hpp"
#include "model/assembly.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/finite_difference.hpp"

#include <catch2/catch.hpp>

#include <iostream>

using namespace fascia;
using namespace fascia::test;

namespace {

std::vector<double> reduced_direction(const Model& model, unsigned seed, double length_scale) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> d(model.dof_count());
  for (int k = 0; k < model.dof_count(); ++k) d[k] = (k % 6 < 3 ? length_scale : 1.0) * u(rng);
  for (int i = 0; i < model.frame_count(); ++i)
    if (model.rigid_parents[i] >= 0)
      for (int k = 0; k < 6; ++k) d[6 * i + k] = 0;
  return d;
}

}  // namespace

TEST_CASE("rigid mapping: reduced gradient and Hessian match finite differences", "[integrate][rigid][fd]") {
  const Model model = coupled_model();
  const bool dynamic = GENERATE(false, true);
  ExternalLoads loads;
  loads.gravity = Vec3{0.5, -9.81, 2.0};
  StepPotential potential(model, loads);
  const RigidMapping& mapping = potential.rigid_mapping();
  REQUIRE(mapping.mapped().size() == 9);
  State state = random_state(model, 21, 0.005, 0.5, 2.0);
  mapping.sync(state);
  if (dynamic) {
    // Start at the evaluation state with translational velocities only: there the inertia
    // Hessian's J_l ~ I (step_potential.hpp) is exact, so the check stays a strict one.
    State start = state;
    for (int k = 0; k < model.dof_count(); ++k) start.velocities[k] = k % 6 < 3 ? 0.3 : 0.0;
    potential.set_dynamic(start, 0.01, 0.5, 0.0);
  }
  // Phi of the reduced configuration: the attached frames are put back on their body.
  const Energy phi = [&](const State& s) {
    State t = s;
    mapping.sync(t);
    return potential.value(t);
  };
  std::vector<double> g;
  potential.gradient(state, g);
  const double scale = norm(g);
  for (int k = 0; k < model.dof_count(); ++k) {
    if (model.rigid_parents[k / 6] >= 0) {
      REQUIRE(g[k] == 0);
      continue;
    }
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = 1.0;
    const double fd = directional_derivative(model, phi, state, e);
    INFO("dof " << k << " fd " << fd << " analytic " << g[k]);
    REQUIRE(std::abs(fd - g[k]) <= 1e-6 * scale);
  }
  potential.prepare_hessian(state);
  const LinearSystem sys = potential.system();
  const std::vector<double> d = reduced_direction(model, 5, 0.05);
  std::vector<double> hd(model.dof_count());
  sys.apply(d.data(), hd.data());
  // The assembled reduced matrix is the same operator on the free DOFs (before the energy
  // evaluations below, which reuse the prepared buffers).
  const Eigen::SparseMatrix<double> H = sys.assemble();
  const Eigen::VectorXd hd_matrix = H * Eigen::Map<const Eigen::VectorXd>(d.data(), model.dof_count());
  for (int k = 0; k < model.dof_count(); ++k)
    if (!sys.fixed[k]) REQUIRE(hd_matrix[k] == Approx(hd[k]).margin(1e-10 * norm(hd)));
  for (int k = 0; k < model.dof_count(); ++k) {
    if (model.rigid_parents[k / 6] >= 0) continue;
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = k % 6 < 3 ? 0.05 : 1.0;
    const double fd = mixed_second_derivative(model, phi, state, d, e);
    INFO("dof " << k << " fd " << fd << " analytic " << hd[k] * e[k]);
    REQUIRE(std::abs(fd - hd[k] * e[k]) <= 1e-5 * norm(hd));
  }
}

TEST_CASE("rigid mapping: the tangent prepared after a gradient at its state is the one prepared alone",
          "[integrate][rigid]") {
  // prepare_hessian() reuses the unreduced gradient of the last gradient() call for the mapping's
  // geometric term when it was taken at the same state and load factor, and computes it otherwise.
  // The operator must be bitwise that of a potential prepared without a gradient before, also after
  // a gradient at another state, at another load factor, or before set_dynamic().
  const Model model = coupled_model();
  ExternalLoads loads;
  loads.gravity = Vec3{0.5, -9.81, 2.0};
  const RigidMapping mapping(model);
  State state = random_state(model, 21, 0.005, 0.5, 2.0), other = random_state(model, 22, 0.005, 0.5, 2.0);
  mapping.sync(state);
  mapping.sync(other);
  State start = state;
  for (int k = 0; k < model.dof_count(); ++k) start.velocities[k] = k % 6 < 3 ? 0.3 : 0.0;
  const std::vector<double> d = reduced_direction(model, 5, 0.05);
  auto product = [&](StepPotential& p) {
    p.prepare_hessian(state);
    std::vector<double> hd(model.dof_count());
    p.system().apply(d.data(), hd.data());
    return hd;
  };
  StepPotential alone(model, loads);
  alone.set_dynamic(start, 0.01, 0.5, 0.0);
  const std::vector<double> reference = product(alone);
  std::vector<double> g;
  StepPotential same(model, loads);
  same.set_dynamic(start, 0.01, 0.5, 0.0);
  same.gradient(state, g);
  CHECK(product(same) == reference);
  StepPotential elsewhere(model, loads);
  elsewhere.set_dynamic(start, 0.01, 0.5, 0.0);
  elsewhere.gradient(other, g);
  CHECK(product(elsewhere) == reference);
  StepPotential before_dynamic(model, loads);
  before_dynamic.gradient(state, g);  // static potential: no inertia in its gradient
  before_dynamic.set_dynamic(start, 0.01, 0.5, 0.0);
  CHECK(product(before_dynamic) == reference);
  ExternalLoads scaled = loads;
  StepPotential rescaled(model, scaled);
  rescaled.set_dynamic(start, 0.01, 0.5, 0.0);
  scaled.scale = 0.5;
  rescaled.gradient(state, g);
  scaled.scale = 1.0;
  CHECK(product(rescaled) == reference);
}

TEST_CASE("free coupled system: backward Euler conserves linear momentum; damping dissipates", "[integrate][coupling]") {
  const Model model = coupled_model();
  SimulationSettings settings;
  settings.integrator = Integrator::backward_euler;
  settings.dt = 0.005;
  settings.newton.tolerance = 1e-10;
  settings.newton.linear.method = LinearMethod::cholmod;

  double final_energy[2] = {0, 0};
  for (int damped = 0; damped < 2; ++damped) {
    settings.rayleigh_mass = damped ? 2.0 : 0.0;
    Simulation sim(model, ExternalLoads{}, settings);  // no gravity, nothing fixed
    StepPotential probe(sim.model(), sim.loads());
    sim.state() = moving_start(sim.model(), probe.rigid_mapping());
    const Momentum p0 = momentum(sim.model(), sim.state());
    double energy = kinetic_energy(sim.model(), sim.state()) + probe.elastic_energy(sim.state());
    double max_angular_drift = 0, max_energy_loss = 0;
    const double energy0 = energy;
    for (int step = 0; step < 20; ++step) {
      sim.step();
      const Momentum p = momentum(sim.model(), sim.state());
      const double e = kinetic_energy(sim.model(), sim.state()) + probe.elastic_energy(sim.state());
      if (!damped) {
        max_energy_loss = std::max(max_energy_loss, 1 - e / energy0);
        // Internal forces of every object sum to zero (translation invariance), and the mapping
        // passes them on unchanged: exact up to the Newton tolerance.
        REQUIRE(norm(p.linear - p0.linear) <= 1e-8 * norm(p0.linear));
        max_angular_drift = std::max(max_angular_drift, norm(p.angular - p0.angular) / norm(p0.angular));
      }
      // Backward Euler dissipates; damping only adds to it. Energy never grows.
      REQUIRE(e <= energy * (1 + 1e-12));
      energy = e;
    }
    final_energy[damped] = energy;
    if (!damped)
      std::cout << "free coupled system, 20 backward-Euler steps of 5 ms: max relative angular momentum drift "
                << max_angular_drift << ", energy lost " << max_energy_loss
                << " of E0 (integrator: variational conserves both, tests/integrate/test_variational_step.cpp)\n";
  }
  REQUIRE(final_energy[1] < final_energy[0]);
}
