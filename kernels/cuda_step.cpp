#include "cuda_step.hpp"

#include "device_memory.hpp"
#include "device_problem.hpp"
#include "integrate/simulation.hpp"
#include "solve/diagonal_shifts.hpp"

#include <iostream>

namespace fascia::gpu {
namespace {

class CudaStep final : public StepBackend {
 public:
  CudaStep(const Model& model, const ExternalLoads& loads, const DeviceOptions& options, double rayleigh_stiffness,
           bool factorise)
      : m_potential(model, loads, options, rayleigh_stiffness), m_state(m_potential.make_state()) {
    if (factorise) m_factor = std::make_unique<DeviceCholesky>(m_potential);
  }

  NewtonResult backward_euler(const State& start, State& trial, double dt, double rayleigh_mass,
                              const NewtonSettings& settings, double reference_force) override {
    m_potential.set_load_scale(1.0);
    m_potential.set_dynamic(start, dt, rayleigh_mass);
    m_state.upload(trial);
    DeviceProblem problem(m_potential, settings.linear, m_factor.get(), m_kept, [&](const DeviceFrames& q) {
      factorising(q, 1.0);
      m_origin.start = start;
      m_origin.dt = dt;
    });
    const NewtonResult r = newton(problem, m_state, settings, reference_force);
    m_state.download(trial);
    trial.velocities.resize(static_cast<size_t>(m_potential.dofs()));
    m_potential.increments(m_state, trial.velocities.data());
    for (double& v : trial.velocities) v /= dt;
    return r;
  }

  NewtonResult variational(const State& start, State& end, double dt, const std::vector<double>& p_start,
                           const NewtonSettings& settings, double force_scale, std::vector<double>& p_end) override {
    m_potential.set_load_scale(1.0);
    m_potential.set_static();
    DeviceVariational& step = variational_step(dt);
    step.set_start(start, p_start);
    m_state.upload(end);
    DeviceVariationalProblem problem(step, m_potential, settings.linear, m_factor.get(), m_kept,
                                     [&](const DeviceFrames& q) {
                                       factorising(q, 1.0);
                                       m_origin.start = start;
                                       m_origin.dt = dt;
                                     });
    const NewtonResult result = newton(problem, m_state, settings, force_scale);
    if (result.converged()) step.end_momenta(m_state, p_end);
    m_state.download(end);
    return result;
  }

  NewtonResult equilibrium(State& state, const NewtonSettings& settings, const LoadStepping& stepping,
                           const std::function<double(double)>& set_load_factor) override {
    m_potential.set_equilibrium();
    m_state.upload(state);
    double load_factor = 1.0;
    DeviceProblem problem(m_potential, settings.linear, m_factor.get(), m_kept, [&](const DeviceFrames& q) {
      factorising(q, load_factor);
      m_origin.start = State{};
      m_origin.dt = 0;
    });
    const NewtonResult r = newton_load_stepping(problem, m_state, settings, stepping, [&](double factor) {
      load_factor = factor;
      m_potential.set_load_scale(factor);
      return set_load_factor(factor);
    });
    m_potential.set_load_scale(1.0);
    m_state.download(state);
    return r;
  }

  double elastic_energy(const State& state) override {
    m_state.upload(state);
    return m_potential.elastic_energy(m_state);
  }

  ReusedTangent kept_tangent() const override {
    ReusedTangent t;
    t.held = m_factor && m_factor->factorised() && !m_kept.stale;
    t.shift_step = m_factor ? m_factor->shift_step() : -1;
    if (!t.held) return t;
    t.origin = m_origin;
    t.pattern = m_factor->fingerprint();
    t.solves = m_kept.solves;
    t.iterations = m_kept.iterations;
    return t;
  }

  bool restore_tangent(const ReusedTangent& tangent, const SimulationSettings& settings) override {
    m_kept = KeptFactorisation{};
    if (!tangent.held) {
      if (m_factor) m_factor->set_first_shift_step(resumed_first_shift_step(tangent.shift_step, false));
      return true;
    }
    if (!m_factor || tangent.pattern != m_factor->fingerprint()) return false;
    m_factor->set_first_shift_step(resumed_first_shift_step(tangent.shift_step, true));
    const TangentOrigin& o = tangent.origin;
    m_potential.set_load_scale(o.load_scale);
    m_state.upload(o.state);
    if (settings.integrator == Integrator::variational) {
      m_potential.set_static();
      DeviceVariational& step = variational_step(o.dt);
      step.set_start(o.start, {});
      step.set_kinetic_blocks(m_state);
      m_potential.prepare_hessian(step.midpoint(m_state), false);
    } else {
      if (settings.integrator == Integrator::static_equilibrium)
        m_potential.set_equilibrium();
      else
        m_potential.set_dynamic(o.start, o.dt, settings.rayleigh_mass);
      m_potential.prepare_hessian(m_state, false);
    }
    m_factor->factorise(m_potential);
    m_potential.set_load_scale(1.0);
    m_origin = o;
    if (!m_factor->factorised()) return false;
    m_kept = KeptFactorisation{false, tangent.solves, tangent.iterations};
    return true;
  }

 private:
  // Records where the next factorisation is computed (a checkpoint keeps it: kept_tangent()).
  void factorising(const DeviceFrames& q, double load_factor) {
    m_origin.load_scale = load_factor;
    q.download(m_origin.state);
    m_origin.state.velocities.assign(6 * m_origin.state.positions.size() / 3, 0.0);
  }

  // The variational step's device terms for step dt (made at the first variational solve).
  DeviceVariational& variational_step(double dt) {
    if (!m_variational || m_variational->dt() != dt) m_variational = std::make_unique<DeviceVariational>(m_potential, dt);
    return *m_variational;
  }

  DevicePotential m_potential;
  DeviceFrames m_state;
  std::unique_ptr<DeviceVariational> m_variational;
  // The factorisation of the cholmod preconditioner: pcg keeps it across Newton
  // iterations and steps as the CPU does (solve/factorised_solve.hpp), and a checkpoint records
  // where it was computed, so that a resumed run computes it again (restore_tangent).
  std::unique_ptr<DeviceCholesky> m_factor;
  KeptFactorisation m_kept;
  TangentOrigin m_origin;
};

// Why the dense factor the settings ask for is not used (empty where it is or is not asked for):
// it does not fit, or, as pcg's preconditioner, it would cost more than block Jacobi
// (DeviceCholesky::kPreconditionerDofs). The device keeps it where DeviceProblem::factorises(linear)
// and this is empty.
std::string dense_refusal(const Model& model, const LinearSettings& linear) {
  if (!DeviceProblem::factorises(linear)) return {};
  if (linear.method == LinearMethod::pcg && model.dof_count() > DeviceCholesky::kPreconditionerDofs)
    return "at " + std::to_string(model.dof_count()) + " DOFs (more than " +
           std::to_string(DeviceCholesky::kPreconditionerDofs) +
           ") the dense factor's renewals cost more than block Jacobi's extra iterations";
  return DeviceCholesky::refusal(model.dof_count(), model.pair_count());
}

// Why the whole step does not run on the device for model and settings (empty when it does): the
// cholmod method without room for the dense factor (pcg falls back to block Jacobi without it).
std::string device_step_refusal(const Model& model, const SimulationSettings& settings) {
  if (settings.newton.linear.method != LinearMethod::cholmod) return {};
  const std::string why = dense_refusal(model, settings.newton.linear);
  return why.empty() ? why : "the linear method is cholmod (a factorisation per Newton iteration), and " + why;
}

// Stiffness-proportional damping acts in backward-Euler steps only (StepPotential::set_dynamic).
double damping(const SimulationSettings& settings) {
  return settings.integrator == Integrator::backward_euler ? settings.rayleigh_stiffness : 0.0;
}

}  // namespace

StepBackendFactory cuda_step_factory(const DeviceOptions& options) {
  return [options](const Model& model, const ExternalLoads& loads, const SimulationSettings& settings,
                   std::string& why) -> std::unique_ptr<StepBackend> {
    why = device_step_refusal(model, settings);
    if (!why.empty()) return nullptr;
    // Where the dense factor is not used, pcg is preconditioned by block Jacobi.
    const LinearSettings& linear = settings.newton.linear;
    const std::string dense = dense_refusal(model, linear);
    if (!dense.empty()) std::cerr << "fascia: note: the device preconditions pcg by block Jacobi: " << dense << "\n";
    return std::make_unique<CudaStep>(model, loads, options, damping(settings),
                                      DeviceProblem::factorises(linear) && dense.empty());
  };
}

std::string device_run_refusal(const Model& model, const SimulationSettings& settings, const DeviceOptions& options,
                               bool sample_rows) {
  DeviceRun run;
  const LinearSettings& linear = settings.newton.linear;
  run.factorised =
      device_step_refusal(model, settings).empty() && DeviceProblem::factorises(linear) && dense_refusal(model, linear).empty();
  run.start_tangent = damping(settings) > 0;
  run.single = options.precision != Precision::double_precision;
  run.variational = settings.integrator == Integrator::variational;
  run.sample_rows = sample_rows;
  size_t free = 0, total = 0;
  FASCIA_CUDA(cudaMemGetInfo(&free, &total));
  return device_memory_refusal(model, run, static_cast<double>(free), static_cast<double>(total));
}

}  // namespace fascia::gpu
