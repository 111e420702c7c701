// Where the factorisation that PCG reuses as its preconditioner (solver.linear: pcg + cholmod,
// solve/linear_solver.hpp) was computed: every input of the assembled step tangent. The
// factorisation lives on from one Newton iteration and step to the next, so a run continued from
// a checkpoint must start with the same one to repeat the uninterrupted run's iterations bit for
// bit: it assembles the tangent again from these inputs and factorises it
// (Simulation::restore_tangent).
//
// The assembled matrix is a function of (StepPotential::system(), VariationalStep::iteration_matrix()):
//   static          the iterate q and the load factor of load stepping (load rotational blocks)
//   backward Euler  q, the step start q_n (inertia R_n I_0 R_n^T, stiffness damping K_n) and h
//   variational     q_k (start) and q_{k+1} (state), h fixed by the scene
// plus the model and the scene's settings, which a checkpoint's scene identity fixes.
#pragma once

#include "model/state.hpp"

#include <cstdint>

namespace fascia {

struct TangentOrigin {
  State start;            // the step start (backward Euler, variational; empty for static)
  State state;            // the iterate the tangent was assembled at
  double dt = 0;          // s, the step size of that attempt
  double load_scale = 1;  // ExternalLoads::scale at the assembly (static load stepping)
};

// The reused factorisation as a checkpoint keeps it.
struct ReusedTangent {
  bool held = false;          // the next solve reuses a factorisation (else it factorises anew)
  TangentOrigin origin;       // where that factorisation's matrix was assembled
  std::uint64_t pattern = 0;  // SparseCholesky::pattern_fingerprint() of its analysis
  // The solves and CG iterations it has served (solve/kept_factorisation.hpp: when it is renewed).
  int solves = 0;
  long long iterations = 0;
  // The shift step of the last factorisation (SparseCholesky::shift_step(), held or not; -1:
  // unshifted or none): where the next factorisation's search for a shift starts.
  int shift_step = -1;
};

}  // namespace fascia
