#include "integrate/simulation.hpp"

#include "core/rotation.hpp"
#include "integrate/step_potential.hpp"
#include "integrate/variational_step.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace fascia {

const char* to_string(Integrator integrator) {
  switch (integrator) {
    case Integrator::static_equilibrium: return "static";
    case Integrator::backward_euler: return "backward_euler";
    case Integrator::variational: return "variational";
  }
  return "?";
}

Integrator parse_integrator(const std::string& name) {
  if (name == "static") return Integrator::static_equilibrium;
  if (name == "backward_euler") return Integrator::backward_euler;
  if (name == "variational") return Integrator::variational;
  throw std::invalid_argument("unknown integrator '" + name + "' (expected static, backward_euler or variational)");
}

double kinetic_energy(const Model& model, const State& state) {
  double e = 0;
  for (int i = 0; i < model.frame_count(); ++i) {
    const Vec3 v = load3(&state.velocities[6 * i]), w = load3(&state.velocities[6 * i + 3]);
    const Mat3 R = rotation_matrix(load_quat(&state.orientations[4 * i]));
    const Mat3 I = R * load_mat3(&model.frame_inertias[9 * i]) * transpose(R);
    e += 0.5 * (model.frame_masses[i] * dot(v, v) + dot(w, I * w));
  }
  return e;
}

struct Simulation::Impl {
  Impl(const Model& model, const ExternalLoads& loads, const SimulationSettings& settings)
      : potential(model, loads, settings.threads, settings.elasticity) {}
  StepPotential potential;
  std::unique_ptr<VariationalStep> variational;
  LinearSolver linear;  // keeps its factorisation from one step to the next
};

Simulation::Simulation(Model model, ExternalLoads loads, SimulationSettings settings,
                       std::vector<PrescribedMotion> motions)
    : m_model(std::move(model)), m_loads(std::move(loads)), m_settings(settings), m_motions(std::move(motions)) {
  if (m_model.fixed_dofs.size() != static_cast<size_t>(m_model.dof_count()))
    m_model.fixed_dofs.resize(m_model.dof_count(), 0);
  fix_prescribed_dofs(m_model, m_motions);
  validate(m_model);
  if (!(m_settings.dt > 0)) throw std::invalid_argument("time step must be > 0 s");
  if (m_settings.integrator == Integrator::variational && (m_settings.rayleigh_mass != 0 || m_settings.rayleigh_stiffness != 0))
    throw std::invalid_argument("the variational integrator takes no Rayleigh damping (use backward_euler)");
  m_state = rest_state(m_model);
  m_impl = std::make_unique<Impl>(m_model, m_loads, m_settings);
  if (m_settings.integrator == Integrator::variational)
    m_impl->variational = std::make_unique<VariationalStep>(m_model, m_impl->potential, m_settings.dt);
}

Simulation::~Simulation() = default;

namespace {

bool finite_state(const State& s) {
  for (double x : s.positions)
    if (!std::isfinite(x)) return false;
  for (double x : s.orientations)
    if (!std::isfinite(x)) return false;
  return true;
}

}  // namespace

StepReport Simulation::step() {
  const auto t0 = std::chrono::steady_clock::now();
  StepPotential& potential = m_impl->potential;
  StepReport report;
  report.step = m_step + 1;
  const double t_next = m_time + m_settings.dt;
  const double reference = load_force_norm(m_model, m_loads);
  State start = m_state;

  if (m_settings.integrator != Integrator::static_equilibrium) {
    // One time step: the variational step solves its discrete Euler-Lagrange equations (with V
    // from the static potential), backward Euler minimises its incremental potential.
    const bool variational = m_settings.integrator == Integrator::variational;
    if (variational)
      potential.set_static();
    else
      potential.set_dynamic(start, m_settings.dt, m_settings.rayleigh_mass, m_settings.rayleigh_stiffness);
    State trial = start;
    apply_motions(m_model, m_motions, t_next, trial);
    potential.rigid_mapping().sync(trial);
    const NewtonResult r =
        variational ? m_impl->variational->advance(start, trial, m_settings.newton, reference, &m_impl->linear)
                    : minimise(potential, trial, m_settings.newton, reference, &m_impl->linear);
    report.newton_iterations = r.iterations;
    report.cg_iterations = r.cg_iterations;
    report.residual = r.residual;
    if (!r.converged || !finite_state(trial)) {
      std::ostringstream msg;
      msg << "step " << report.step << " (t = " << t_next << " s): "
          << (finite_state(trial) ? r.message : "the state became non-finite (diverged)");
      throw SolverError(msg.str());
    }
    if (!variational) {  // the variational step sets its velocities from the momenta
      std::vector<double> delta;
      potential.increments(trial, delta);
      for (size_t k = 0; k < delta.size(); ++k) trial.velocities[k] = delta[k] / m_settings.dt;
    }
    m_state = std::move(trial);
  } else {
    // Static equilibrium with load stepping (solve/newton.hpp).
    potential.set_static();
    State trial = start;
    apply_motions(m_model, m_motions, t_next, trial);
    potential.rigid_mapping().sync(trial);
    ExternalLoads& loads = m_loads;
    LoadStepping stepping;
    stepping.initial_steps = m_settings.load_steps;
    stepping.max_halvings = m_settings.max_load_halvings;
    const NewtonResult r = minimise_load_stepping(potential, trial, m_settings.newton, stepping, [&](double factor) {
      loads.scale = factor;
      return load_force_norm(m_model, loads);
    }, &m_impl->linear);
    loads.scale = 1.0;
    report.newton_iterations = r.iterations;
    report.cg_iterations = r.cg_iterations;
    if (!r.converged || !finite_state(trial)) throw SolverError(r.converged ? "the state became non-finite (diverged)" : r.message);
    report.residual = r.residual;
    std::fill(trial.velocities.begin(), trial.velocities.end(), 0.0);
    m_state = std::move(trial);
  }
  report.time = t_next;
  report.converged = true;
  report.elastic_energy = potential.elastic_energy(m_state);
  report.kinetic_energy = kinetic_energy(m_model, m_state);
  report.external_potential = load_potential(m_model, m_loads, m_state);
  // A step is accepted only with a finite state and finite energies: values beyond the range of
  // a double (a modulus of 1e300 Pa, a time step of 1e-300 s) are a divergence, never output.
  const bool finite_velocities =
      std::all_of(m_state.velocities.begin(), m_state.velocities.end(), [](double v) { return std::isfinite(v); });
  if (!finite_velocities || !std::isfinite(report.elastic_energy) || !std::isfinite(report.kinetic_energy) ||
      !std::isfinite(report.external_potential)) {
    std::ostringstream msg;
    msg << "step " << report.step << " (t = " << t_next << " s): "
        << (finite_velocities ? "the energy became non-finite" : "the velocities became non-finite")
        << " (diverged; elastic " << report.elastic_energy << " J, kinetic " << report.kinetic_energy
        << " J, external " << report.external_potential
        << " J); check the scene's magnitudes (moduli, loads, dt) and units";
    m_state = std::move(start);
    throw SolverError(msg.str());
  }
  ++m_step;
  m_time = t_next;
  report.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

}  // namespace fascia
