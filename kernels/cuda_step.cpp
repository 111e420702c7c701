#include "cuda_step.hpp"

#include "device_problem.hpp"
#include "integrate/simulation.hpp"

namespace fascia::gpu {
namespace {

class CudaStep final : public StepBackend {
 public:
  CudaStep(const Model& model, const ExternalLoads& loads, const DeviceOptions& options)
      : m_potential(model, loads, options), m_state(m_potential.make_state()) {}

  NewtonResult backward_euler(const State& start, State& trial, double dt, double rayleigh_mass,
                              const NewtonSettings& settings, double reference_force) override {
    m_potential.set_load_scale(1.0);
    m_potential.set_dynamic(start, dt, rayleigh_mass);
    m_state.upload(trial);
    DeviceProblem problem(m_potential, settings.linear);
    const NewtonResult r = newton(problem, m_state, settings, reference_force);
    m_state.download(trial);
    trial.velocities.resize(static_cast<size_t>(m_potential.dofs()));
    m_potential.increments(m_state, trial.velocities.data());
    for (double& v : trial.velocities) v /= dt;
    return r;
  }

  NewtonResult equilibrium(State& state, const NewtonSettings& settings, const LoadStepping& stepping,
                           const std::function<double(double)>& set_load_factor) override {
    m_potential.set_static();
    m_state.upload(state);
    DeviceProblem problem(m_potential, settings.linear);
    const NewtonResult r = newton_load_stepping(problem, m_state, settings, stepping, [&](double factor) {
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

 private:
  DevicePotential m_potential;
  DeviceFrames m_state;
};

}  // namespace

StepBackendFactory cuda_step_factory(const DeviceOptions& options) {
  return [options](const Model& model, const ExternalLoads& loads, const SimulationSettings& settings,
                   std::string& why) -> std::unique_ptr<StepBackend> {
    if (!DeviceProblem::supported(settings.newton.linear)) {
      why = "the linear method is cholmod (a direct solve), which runs on the CPU";
      return nullptr;
    }
    why = device_potential_refusal(model, settings.integrator == Integrator::backward_euler ? settings.rayleigh_stiffness : 0.0);
    if (!why.empty()) return nullptr;
    return std::make_unique<CudaStep>(model, loads, options);
  };
}

}  // namespace fascia::gpu
