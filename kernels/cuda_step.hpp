// The CUDA step backend (engine/integrate/step_backend.hpp): `fascia run --backend cuda` with the
// whole step on the device. Each solve uploads the start state once (positions, orientations,
// velocities: 13 N doubles), runs Newton, the line search and the PCG over device vectors
// (device_newton.hpp) on the device potential (device_potential.hpp), and reads the result back
// once; inside, only the scalars that steer the iterations cross the bus.
//
// Covered: the static and backward-Euler integrators with cg or pcg on every model (tissues,
// shells, rigid bodies and their attached frames), without stiffness-proportional damping. On the
// device pcg is preconditioned by block Jacobi, also where the scene asks for the CPU's sparse
// factorisation (solver.linear.preconditioner: cholmod, the default), which has no device
// counterpart: the same tolerance, more CG iterations. Elsewhere the factory returns null with the
// reason, and Simulation runs the CPU engine with the volumetric elasticity on the device
// (cuda_elasticity.hpp).
#pragma once

#include "device_elasticity.hpp"
#include "integrate/step_backend.hpp"

namespace fascia::gpu {

StepBackendFactory cuda_step_factory(const DeviceOptions& options = {});

}  // namespace fascia::gpu
