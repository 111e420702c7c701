#include "cuda_step.hpp"

#include "device_newton.hpp"
#include "device_potential.hpp"
#include "integrate/simulation.hpp"

namespace fascia::gpu {
namespace {

class CudaStep final : public StepBackend {
 public:
  CudaStep(const Model& model, const ExternalLoads& loads, const DeviceOptions& options)
      : m_potential(model, loads, options) {}

  NewtonResult backward_euler(const State& start, State& trial, double dt, double rayleigh_mass,
                              const NewtonSettings& settings, double reference_force) override {
    m_potential.set_load_scale(1.0);
    m_potential.set_dynamic(start, dt, rayleigh_mass);
    m_potential.upload(DevicePotential::kCurrent, trial);
    const NewtonResult r = minimise_on_device(m_potential, settings, reference_force);
    m_potential.download(DevicePotential::kCurrent, trial);
    trial.velocities.resize(static_cast<size_t>(m_potential.dofs()));
    m_potential.increments(DevicePotential::kCurrent, trial.velocities.data());
    for (double& v : trial.velocities) v /= dt;
    return r;
  }

  NewtonResult equilibrium(State& state, double load_scale, const NewtonSettings& settings,
                           double reference_force) override {
    m_potential.set_static();
    m_potential.set_load_scale(load_scale);
    m_potential.upload(DevicePotential::kCurrent, state);
    const NewtonResult r = minimise_on_device(m_potential, settings, reference_force);
    m_potential.download(DevicePotential::kCurrent, state);
    return r;
  }

  double elastic_energy(const State& state) override {
    m_potential.upload(DevicePotential::kTrial, state);
    return m_potential.elastic_energy(DevicePotential::kTrial);
  }

 private:
  DevicePotential m_potential;
};

}  // namespace

StepBackendFactory cuda_step_factory(const DeviceOptions& options) {
  return [options](const Model& model, const ExternalLoads& loads, const SimulationSettings& settings,
                   std::string& why) -> std::unique_ptr<StepBackend> {
    if (settings.newton.linear.method == LinearMethod::cholmod) {
      why = "the linear method is cholmod, which runs on the CPU";
      return nullptr;
    }
    why = device_potential_refusal(model, settings.integrator == Integrator::backward_euler ? settings.rayleigh_stiffness : 0.0);
    if (!why.empty()) return nullptr;
    return std::make_unique<CudaStep>(model, loads, options);
  };
}

}  // namespace fascia::gpu
