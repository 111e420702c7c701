#include "integrate/simulation.hpp"

#include "core/rotation.hpp"
#include "integrate/step_potential.hpp"
#include "integrate/variational_step.hpp"
#include "solve/sparse_cholesky.hpp"

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
      : backend(make_backend(model, loads, settings, refusal)),
        potential(model, loads, settings.threads, backend ? ElasticityFactory{} : settings.elasticity) {
    // The CPU engine's elasticity now, so that a factory's refusal stops the construction; a
    // backend's run never makes it.
    if (!backend) potential.elasticity();
  }
  static std::unique_ptr<StepBackend> make_backend(const Model& model, const ExternalLoads& loads,
                                                   const SimulationSettings& settings, std::string& why) {
    if (!settings.step_backend) return nullptr;
    return settings.step_backend(model, loads, settings, why);
  }
  std::string refusal;                   // why the step backend does not run the steps
  std::unique_ptr<StepBackend> backend;  // null: the CPU engine (StepPotential) solves
  StepPotential potential;  // the CPU engine; with a backend, prescribed motions and rigid sync only
  std::unique_ptr<VariationalStep> variational;
  LinearSolver linear;  // keeps its factorisation from one step to the next
};

bool Simulation::on_step_backend() const { return m_impl->backend != nullptr; }
const std::string& Simulation::step_backend_refusal() const { return m_impl->refusal; }

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
  if (m_settings.adaptive.enabled) {
    if (m_settings.integrator == Integrator::variational)
      throw std::invalid_argument("adaptive time steps need the backward_euler or static integrator");
    const AdaptiveSettings& a = m_settings.adaptive;
    if (!(a.tolerance > 0) || !(a.min_dt > 0) || (a.max_dt > 0 && a.max_dt < a.min_dt))
      throw std::invalid_argument("adaptive steps need tolerance > 0, min_dt > 0 and max_dt >= min_dt");
    m_controller = std::make_unique<StepController>(
        a, m_settings.dt, m_settings.integrator == Integrator::static_equilibrium ? 1 : 2);
    m_extent = model_extent(m_model);
  }
}

Simulation::~Simulation() = default;

void Simulation::restore(const State& state, int step, double time) {
  if (state.positions.size() != m_state.positions.size() || state.orientations.size() != m_state.orientations.size() ||
      state.velocities.size() != m_state.velocities.size())
    throw std::invalid_argument("restored state has " + std::to_string(state.frame_count()) + " frames, the model " +
                                std::to_string(m_state.frame_count()));
  m_state = state;
  m_step = step;
  m_time = time;
  m_history = PathHistory{};
}

void Simulation::restore_path_history(const PathHistory& history) {
  if (history.held() && (history.previous.positions.size() != m_state.positions.size() ||
                         history.previous.orientations.size() != m_state.orientations.size() ||
                         history.previous.velocities.size() != m_state.velocities.size()))
    throw std::invalid_argument("restored path history has " + std::to_string(history.previous.frame_count()) +
                                " frames, the model " + std::to_string(m_state.frame_count()));
  m_history = history.held() ? history : PathHistory{};
}

void Simulation::record_history(State start, double h) {
  // Static steps: only a step between two equilibria lies on the path (the first starts from the
  // rest state, not an equilibrium of the loads). Backward Euler: every step, whose velocities
  // give the next guess's acceleration. The variational step makes no guess.
  const Integrator integrator = m_settings.integrator;
  if (integrator == Integrator::variational || (integrator == Integrator::static_equilibrium && m_step == 0)) return;
  m_history.previous = std::move(start);
  m_history.dt = h;
}

void Simulation::keep_tangent() {
  if (m_impl->backend) {
    m_reused = m_impl->backend->kept_tangent();
    return;
  }
  const LinearSettings& linear = m_settings.newton.linear;
  m_reused.held = linear.method == LinearMethod::pcg &&
                  linear.preconditioner == Preconditioner::cholmod && m_impl->linear.reuses_factorisation();
  if (!m_reused.held) {
    m_reused = ReusedTangent{};
    m_reused.shift_step = m_impl->linear.factorisation().shift_step();
    return;
  }
  m_reused.origin = m_impl->variational ? m_impl->variational->assembled_at() : m_impl->potential.assembled_at();
  m_reused.pattern = m_impl->linear.factorisation().pattern_fingerprint();
  m_reused.solves = m_impl->linear.kept().solves;
  m_reused.iterations = m_impl->linear.kept().iterations;
  m_reused.shift_step = m_impl->linear.factorisation().shift_step();
}

bool Simulation::restore_tangent(const ReusedTangent& tangent) {
  m_reused = tangent;
  if (m_impl->backend) return m_impl->backend->restore_tangent(tangent, m_settings);
  if (!tangent.held) {
    m_impl->linear.restore_shift(tangent.shift_step);
    return true;
  }
  const TangentOrigin& o = tangent.origin;
  if (o.state.frame_count() != m_model.frame_count())
    throw std::invalid_argument("restored tangent origin has " + std::to_string(o.state.frame_count()) +
                                " frames, the model " + std::to_string(m_model.frame_count()));
  StepPotential& potential = m_impl->potential;
  LinearSystem system;
  if (m_settings.integrator == Integrator::variational) {
    potential.set_static();
    system = m_impl->variational->iteration_matrix(o.start, o.state);
  } else {
    if (m_settings.integrator == Integrator::static_equilibrium)
      potential.set_equilibrium();
    else
      potential.set_dynamic(o.start, o.dt, m_settings.rayleigh_mass, m_settings.rayleigh_stiffness);
    m_loads.scale = o.load_scale;
    potential.prepare_hessian(o.state);
    system = potential.system();
  }
  KeptFactorisation served;
  served.solves = tangent.solves;
  served.iterations = tangent.iterations;
  const bool factorised = m_impl->linear.restore_factorisation(system, served, tangent.shift_step);
  m_loads.scale = 1.0;
  return factorised && m_impl->linear.factorisation().pattern_fingerprint() == tangent.pattern;
}

namespace {

bool finite_state(const State& s) {
  for (double x : s.positions)
    if (!std::isfinite(x)) return false;
  for (double x : s.orientations)
    if (!std::isfinite(x)) return false;
  for (double x : s.velocities)
    if (!std::isfinite(x)) return false;
  return true;
}

// The likely cause of a failed step, from how Newton stopped, and the remedy: a smaller dt, or
// adaptive steps where the integrator takes them (not the variational one) and the run does not
// already have them.
std::string likely_cause(const NewtonResult& r, bool finite, bool adaptive, Integrator integrator) {
  const bool variational = integrator == Integrator::variational;
  const std::string smaller = adaptive      ? ""
                              : variational ? "; a smaller solver.dt resolves it"
                                            : "; a smaller solver.dt, or solver.adaptive, resolves it";
  if (!finite) return "the state became non-finite (diverged): the step is too large for the load" + smaller;
  switch (r.stop) {
    case NewtonStop::inadmissible_start:
      return "an element inverts at the start of the step: prescribed motions or loads move frames farther in one "
             "step than the elements allow" + smaller;
    case NewtonStop::line_search:
    case NewtonStop::krylov_stall:
    case NewtonStop::inadmissible_probe:
      if (variational)
        return "no decrease of the residual even along Newton-Krylov directions: the discrete equations have no "
               "solution near the predicted state, or one the residual cannot be driven to from there (large "
               "rotations per step, elastic torques on frames of small rotational inertia)" + smaller;
      return "no descent along the Newton direction: an indefinite tangent (buckling, inverted elements) or a load "
             "too large for one step" + smaller;
    case NewtonStop::converged:
    case NewtonStop::iteration_cap:
    case NewtonStop::non_finite:
      break;
  }
  return "slow convergence: a near-singular tangent (unconstrained frames, zero-energy modes) or too large a step" +
         smaller;
}

}  // namespace

struct Simulation::Attempt {
  NewtonResult newton;
  State predicted;  // adaptive static steps with a path history: the predicted start
  bool finite = true;
  bool ok() const { return newton.converged() && finite; }
};

Simulation::Attempt Simulation::attempt(double h, State& trial) {
  // The variational step solves its discrete Euler-Lagrange equations (with V from the static
  // potential), backward Euler minimises its incremental potential.
  StepPotential& potential = m_impl->potential;
  const double reference = potential.frame_loads().force_norm(m_loads.scale);
  const bool variational = m_settings.integrator == Integrator::variational;
  if (variational)
    potential.set_static();
  else
    potential.set_dynamic(m_state, h, m_settings.rayleigh_mass, m_settings.rayleigh_stiffness);
  trial = m_state;
  apply_motions(m_model, m_motions, m_time + h, trial);
  if (!variational) predict_dynamic_step(m_model, m_history, m_state, h, m_settings.rayleigh_mass, trial);
  potential.rigid_mapping().sync(trial);
  Attempt a;
  StepBackend* backend = m_impl->backend.get();
  a.newton = variational ? m_impl->variational->advance(m_state, trial, m_settings.newton, reference, &m_impl->linear,
                                                        backend)
             : backend   ? backend->backward_euler(m_state, trial, h, m_settings.rayleigh_mass, m_settings.newton, reference)
                         : minimise(potential, trial, m_settings.newton, reference, &m_impl->linear);
  // The variational step sets its velocities from the momenta, the backend from its increments.
  if (!variational && !backend && a.newton.converged()) {
    std::vector<double> delta;
    potential.increments(trial, delta);
    for (size_t k = 0; k < delta.size(); ++k) trial.velocities[k] = delta[k] / h;
  }
  keep_tangent();
  a.finite = finite_state(trial);
  return a;
}

Simulation::Attempt Simulation::static_attempt(double t_next, State& trial) {
  // Static equilibrium at t_next with load stepping (solve/newton.hpp), from the current state.
  StepPotential& potential = m_impl->potential;
  potential.set_equilibrium();
  trial = m_state;
  apply_motions(m_model, m_motions, t_next, trial);
  predict_static_step(m_model, m_history, m_state, t_next - m_time, trial);
  potential.rigid_mapping().sync(trial);
  Attempt a;
  if (m_controller && m_history.held()) a.predicted = trial;  // the error estimate's reference
  ExternalLoads& loads = m_loads;
  // Adaptive steps after the first hold the loads at full scale already (m_state is their
  // equilibrium): one Newton solve, whose failure the step controller answers with a shorter step
  // (the motions' increment is what shortens; scaling the loads down would not).
  const bool loaded = m_controller && m_step > 0;
  LoadStepping stepping;
  stepping.initial_steps = loaded ? 1 : m_settings.load_steps;
  stepping.max_halvings = loaded ? 0 : m_settings.max_load_halvings;
  const std::function<double(double)> set_load_factor = [&](double factor) {
    loads.scale = factor;
    return potential.frame_loads().force_norm(factor);
  };
  a.newton = m_impl->backend
                 ? m_impl->backend->equilibrium(trial, m_settings.newton, stepping, set_load_factor)
                 : minimise_load_stepping(potential, trial, m_settings.newton, stepping, set_load_factor, &m_impl->linear);
  loads.scale = 1.0;
  keep_tangent();
  a.finite = finite_state(trial);
  std::fill(trial.velocities.begin(), trial.velocities.end(), 0.0);
  return a;
}

double Simulation::external_potential(const State& state) const {
  return m_impl->potential.frame_loads().value(state, m_loads.scale);
}

bool Simulation::finish(StepReport& report, int step, double time, std::chrono::steady_clock::time_point t0) {
  report.step = step;
  report.time = time;
  report.converged = true;
  report.elastic_energy =
      m_impl->backend ? m_impl->backend->elastic_energy(m_state) : m_impl->potential.elastic_energy(m_state);
  report.kinetic_energy = kinetic_energy(m_model, m_state);
  report.external_potential = external_potential(m_state);
  report.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // A step is accepted only with a finite state and finite energies: values beyond the range of
  // a double (a modulus of 1e300 Pa, a time step of 1e-300 s) are a divergence, never output.
  const bool finite_velocities =
      std::all_of(m_state.velocities.begin(), m_state.velocities.end(), [](double v) { return std::isfinite(v); });
  if (finite_velocities && std::isfinite(report.elastic_energy) && std::isfinite(report.kinetic_energy) &&
      std::isfinite(report.external_potential))
    return true;
  std::ostringstream msg;
  msg << "step " << step << " (t = " << time << " s): "
      << (finite_velocities ? "the energy became non-finite" : "the velocities became non-finite")
      << " (diverged; elastic " << report.elastic_energy << " J, kinetic " << report.kinetic_energy
      << " J, external " << report.external_potential << " J); check the scene's magnitudes (moduli, loads, dt) and units";
  report.converged = false;
  report.message = msg.str();
  return false;
}

StepReport Simulation::step() {
  const auto t0 = std::chrono::steady_clock::now();
  StepReport report;
  report.accepted_steps = 1;
  report.dt = m_settings.dt;
  const double t_next = m_time + m_settings.dt;
  State start = m_state;
  State trial;
  const Attempt a = m_settings.integrator == Integrator::static_equilibrium ? static_attempt(t_next, trial)
                                                                            : attempt(m_settings.dt, trial);
  report.newton_iterations = a.newton.iterations;
  report.cg_iterations = a.newton.cg_iterations;
  report.residual = a.newton.residual;
  if (!a.ok()) {
    std::ostringstream msg;
    msg << "step " << m_step + 1 << " (t = " << t_next << " s, dt = " << m_settings.dt
        << " s) failed: " << (a.finite ? a.newton.message : "non-finite state") << "; relative residual "
        << a.newton.residual << "; likely cause: " << likely_cause(a.newton, a.finite, false, m_settings.integrator);
    throw SolverError(msg.str());
  }
  m_state = std::move(trial);
  if (!finish(report, m_step + 1, t_next, t0)) {
    m_state = std::move(start);
    throw SolverError(report.message);
  }
  record_history(std::move(start), m_settings.dt);
  ++m_step;
  m_time = t_next;
  return report;
}

StepReport Simulation::advance_to(double t_target) {
  if (!m_controller) throw std::logic_error("Simulation::advance_to: adaptive steps are off");
  const auto t0 = std::chrono::steady_clock::now();
  StepController& controller = *m_controller;
  const bool is_static = m_settings.integrator == Integrator::static_equilibrium;
  StepReport report;
  State trial, previous;
  double previous_time = m_time;
  // m_progress holds the counts of the attempts so far (a stop abandons the attempt in progress
  // and keeps them for a checkpoint); the report gives them when the target is reached.
  while (m_time < t_target) {
    const double h = controller.next_step(m_time, t_target);
    const Attempt a = is_static ? static_attempt(m_time + h, trial) : attempt(h, trial);
    m_progress.newton_iterations += a.newton.iterations;
    m_progress.cg_iterations += a.newton.cg_iterations;
    report.residual = a.newton.residual;
    if (!a.ok()) {
      if (controller.failed(h)) {
        ++m_progress.rejected;
        continue;
      }
      std::ostringstream msg;
      msg << "step " << m_step + 1 << " (t = " << m_time << " s to " << m_time + h << " s) failed at the minimum "
          << "step " << h << " s: " << (a.finite ? a.newton.message : "non-finite state") << "; relative residual "
          << a.newton.residual << "; likely cause: " << likely_cause(a.newton, a.finite, true, m_settings.integrator);
      throw SolverError(msg.str());
    }
    // Static steps: the distance from the predicted start (O(h^2)) where there is one, the
    // increment (O(h)) on the first step (step_error.hpp).
    const bool predicted = is_static && !a.predicted.positions.empty();
    const double error = !is_static  ? local_error(m_model, m_state, trial, h, m_extent)
                         : predicted ? static_increment(m_model, a.predicted, trial, m_extent)
                                     : static_increment(m_model, m_state, trial, m_extent);
    if (!controller.update(h, error, is_static && !predicted ? 1 : 2)) {
      ++m_progress.rejected;
      continue;
    }
    std::swap(previous, m_state);
    std::swap(m_state, trial);
    record_history(previous, h);
    previous_time = m_time;
    ++m_step;
    ++m_progress.accepted;
    report.dt = h;
    // The last step lands on t_target exactly, whatever the round-off of the sum of steps.
    m_time = m_time + h >= t_target - 1e-12 * std::max(1.0, std::abs(t_target)) ? t_target : m_time + h;
  }
  report.newton_iterations = static_cast<int>(m_progress.newton_iterations);
  report.cg_iterations = static_cast<int>(m_progress.cg_iterations);
  report.accepted_steps = static_cast<int>(m_progress.accepted);
  report.rejected_steps = static_cast<int>(m_progress.rejected);
  m_progress = AdvanceProgress{};
  if (!finish(report, m_step, m_time, t0)) {
    // Back to the step before when this call took it (not a step before a restore).
    if (previous.positions.empty()) throw SolverError(report.message);
    m_state = std::move(previous);  // back to the step before, whose energies were finite
    m_history = PathHistory{};
    m_time = previous_time;
    --m_step;
    throw SolverError(report.message);
  }
  return report;
}

}  // namespace fascia
