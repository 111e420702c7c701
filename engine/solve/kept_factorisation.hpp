// The state of a factorisation kept as PCG's preconditioner between solves
// (solve/factorised_solve.hpp), and the CPU's rule for when it stops paying.
//
// A factorisation and the solves it serves cost c + i_1 + ... + i_k CG iterations (c: the
// factorisation's cost in CG iterations of those solves, i_j: the iterations of the j-th solve).
// The mean over the solves falls while the next solve costs less than the mean so far, so the
// factorisation is renewed after the first solve k with k i_k > c + i_1 + ... + i_k: the
// replacement rule of an ageing machine. A fresh factorisation's solves take few iterations, and
// more as the tangent moves away from it; solves that stay as costly as the first never renew it.
// Counted in iterations, not timed, so that runs repeat bit for bit; a checkpoint keeps the
// counts. Each factorisation states its cost c: CHOLMOD's (solve/linear_solver.hpp) and the
// device's (kernels/device_cholesky.hpp).
#pragma once

namespace fascia {

// Whether the next solve factorises first, and the solves and CG iterations the factorisation
// has served since it was computed.
struct KeptFactorisation {
  bool stale = true;
  int solves = 0;
  long long iterations = 0;
};

// Whether a factorisation of cost `cost` (CG iterations) stops paying after the solve of
// `iterations` that `kept` has just counted (the rule above).
inline bool stops_paying(const KeptFactorisation& kept, int iterations, double cost) {
  return static_cast<double>(iterations) * kept.solves > cost + static_cast<double>(kept.iterations);
}

}  // namespace fascia
