// Newton's method with the Armijo line search and the (block-Jacobi preconditioned) conjugate
// gradients of engine/solve/newton.cpp and engine/solve/linear_solver.cpp, run over a
// DevicePotential: every vector stays on the device; the host reads the scalars that steer the
// iterations (dot products, energies), a few bytes at a time.
//
// The same algorithm, the same settings and the same stopping rules as the CPU solver
// (NewtonSettings), so that a step on either backend stops at the same relative residual. The
// linear method must be cg or pcg (CHOLMOD has no device counterpart; the caller chooses).
#pragma once

#include "device_potential.hpp"
#include "solve/newton.hpp"

namespace fascia::gpu {

// Minimises the potential from slot DevicePotential::kCurrent, which holds the result.
NewtonResult minimise_on_device(DevicePotential& potential, const NewtonSettings& settings, double reference_force);

}  // namespace fascia::gpu
