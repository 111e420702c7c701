// The CUDA step backend (engine/integrate/step_backend.hpp): `fascia run --backend cuda` with the
// whole step on the device. Each solve uploads the start state once (positions, orientations,
// velocities: 13 N doubles), runs the one Newton with its line search and the one PCG over device
// vectors (device_problem.hpp) on the device potential (device_potential.hpp), and reads the
// result back once; inside, only the scalars that steer the iterations cross the bus.
//
// Covered: every integrator (static, backward Euler with Rayleigh damping, variational:
// device_variational.hpp) with cg, pcg or cholmod on every model (tissues, shells, rigid bodies
// and their attached frames). pcg is preconditioned by block Jacobi or, with
// solver.linear.preconditioner: cholmod (the default), by the device's dense Cholesky factor kept
// across Newton iterations and steps (device_cholesky.hpp), or by block Jacobi where that factor
// would not fit or the model has more than DeviceCholesky::kPreconditionerDofs DOFs. The cholmod
// method without room for that factor is refused: the factory returns null with the reason, and
// Simulation runs the CPU engine with the volumetric elasticity on the device
// (cuda_elasticity.hpp).
#pragma once

#include "device_elasticity.hpp"
#include "integrate/step_backend.hpp"

namespace fascia::gpu {

StepBackendFactory cuda_step_factory(const DeviceOptions& options = {});

// Why a run of model with settings does not fit in the device's free memory (empty when it does):
// the step the factory makes (or the elasticity behind the CPU step) and, with `sample_rows`, the
// output rows' sample fields (device_memory.hpp).
std::string device_run_refusal(const Model& model, const SimulationSettings& settings, const DeviceOptions& options,
                               bool sample_rows);

}  // namespace fascia::gpu
