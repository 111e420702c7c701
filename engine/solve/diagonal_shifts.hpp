// The diagonal shifts tau of a tangent that is not positive definite: its factorisation
// (solve/sparse_cholesky.hpp) factorises H + tau diag|H| with the first of these that succeeds,
// named by their step k (-1: unshifted), which checkpoints keep (io/checkpoint.hpp).
#pragma once

namespace fascia {

constexpr int kShiftSteps = 10;
constexpr double kShifts[kShiftSteps] = {1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1e0, 1e1, 1e2, 1e3};

}  // namespace fascia
