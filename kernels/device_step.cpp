#include "device_step.hpp"

#include "mechanics/frame_loads.hpp"

#include <stdexcept>

namespace fascia::gpu {

StepOptions make_step_options(const Model& model, const ExternalLoads& loads, const State& start, double dt,
                              double rayleigh_mass, double rayleigh_stiffness, const LinearSettings& linear) {
  if (linear.method == LinearMethod::cholmod)
    throw std::invalid_argument("the CUDA backend solves with cg or pcg, not cholmod");
  const int n = model.frame_count();
  StepOptions o;
  o.dt = dt;
  o.rayleigh_mass = rayleigh_mass;
  o.rayleigh_stiffness = rayleigh_stiffness;
  o.preconditioner = linear.method == LinearMethod::pcg;
  o.max_cg_iterations = linear.max_iterations;
  o.cg_tolerance = linear.fixed_iterations ? 0.0 : linear.tolerance;
  const FrameLoads frame_loads(model, loads);
  std::vector<double> g(6 * static_cast<size_t>(n), 0.0);
  frame_loads.add_gradient(start, loads.scale, g.data());
  o.external_forces.resize(g.size());
  for (size_t k = 0; k < g.size(); ++k) o.external_forces[k] = -g[k];
  o.load_rotational_blocks.assign(9 * static_cast<size_t>(n), 0.0);
  frame_loads.add_rotational_blocks(start, loads.scale, o.load_rotational_blocks.data());
  return o;
}

namespace {

// The device step covers volumetric frame models only; refuse what it would get wrong.
const Model& supported(const Model& model) {
  bool rigid = false;
  for (int p : model.rigid_parents) rigid = rigid || p >= 0;
  bool point_masses = false;
  for (double m : model.frame_point_masses) point_masses = point_masses || m != 0;
  if (!model.shells.empty() || rigid || point_masses)
    throw std::invalid_argument(
        "the CUDA backend does not support shells, rigid bodies or frame point masses yet; use --backend cpu");
  return model;
}

}  // namespace

DeviceImplicitStep::DeviceImplicitStep(const Model& model, const DeviceOptions& options)
    : m_model(supported(model)), m_elasticity(model, options) {}

StepReport DeviceImplicitStep::step(State& state, const ExternalLoads& loads, double dt, double rayleigh_mass,
                                    double rayleigh_stiffness, const LinearSettings& linear) {
  m_elasticity.set_state(state);
  DeviceBackwardEuler stepper(
      m_elasticity, make_step_options(m_model, loads, state, dt, rayleigh_mass, rayleigh_stiffness, linear));
  const StepReport report = stepper.step();
  m_elasticity.get_state(state);
  return report;
}

}  // namespace fascia::gpu
