// The diagonal shifts tau of a tangent that is not positive definite, named by their step k
// (-1: unshifted), which checkpoints keep (io/checkpoint.hpp). A factorisation (CPU:
// solve/sparse_cholesky.hpp, CUDA: kernels/device_cholesky.hpp) tries H unshifted, then
// H + tau diag|H| from the step first_shift_step(last) on until one succeeds, `last` being the
// last factorisation's step: one decade below it, since a run's tangents change little between
// factorisations. A run that needed a shift finds about the same one again in two or three
// numeric factorisations instead of one per decade from the smallest, and a tangent positive
// definite again is factorised unshifted, so that modified Newton's directions stay Newton's.
#pragma once

namespace fascia {

constexpr int kShiftSteps = 10;
constexpr double kShifts[kShiftSteps] = {1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1e0, 1e1, 1e2, 1e3};

// The first shifted step tried after a factorisation whose step was `last`.
constexpr int first_shift_step(int last) { return last > 0 ? last - 1 : 0; }

}  // namespace fascia
