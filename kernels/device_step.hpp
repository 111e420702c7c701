// The CPU engine's backward-Euler step of one Newton iteration on the device: what `fascia bench
// gpu` times and what the GPU tests compare with fascia::minimise. (`fascia run --backend cuda`
// steps through kernels/device_problem.hpp.)
//
// One step from state q_n = minimise(StepPotential::set_dynamic(q_n, h, alpha, beta), q,
// NewtonSettings{fixed_iterations = 1, linear}) followed by v = Delta / h
// (engine/integrate/step_potential.hpp, engine/solve/newton.hpp): one Newton iteration, the linear
// solve by CG (LinearMethod::cg) or block-Jacobi PCG (LinearMethod::pcg) on the free DOFs. The
// load potential V (gravity on the samples, point forces) enters as its gradient and rotational
// Hessian blocks at q_n, which is exact for the one linearisation the step takes.
// CHOLMOD has no device counterpart: LinearMethod::cholmod is rejected.
#pragma once

#include "device_elasticity.hpp"
#include "mechanics/external_loads.hpp"
#include "solve/linear_solver.hpp"

namespace fascia::gpu {

// StepOptions for the step from `start`: f_ext = -dV/dtheta and the rotational blocks of V at
// `start`, the linear method and its iteration count. Linear tolerance mode (fixed_iterations
// false) stops on sqrt(r.z / r0.z0) <= tolerance, the CPU on |r| <= tolerance |b|.
StepOptions make_step_options(const Model& model, const ExternalLoads& loads, const State& start, double dt,
                              double rayleigh_mass, double rayleigh_stiffness, const LinearSettings& linear);

// A model kept on the device that advances host states by the step above, the state uploaded and
// read back every step (positions, orientations, velocities): the GPU tests' comparison with the
// CPU engine's step.
class DeviceImplicitStep {
 public:
  explicit DeviceImplicitStep(const Model& model, const DeviceOptions& options = {});
  StepReport step(State& state, const ExternalLoads& loads, double dt, double rayleigh_mass,
                  double rayleigh_stiffness, const LinearSettings& linear);
  DeviceElasticity& elasticity() { return m_elasticity; }

 private:
  const Model& m_model;
  DeviceElasticity m_elasticity;
};

}  // namespace fascia::gpu
