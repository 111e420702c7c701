// The diagonal shifts tau of a tangent that is not positive definite, named by their step k
// (-1: unshifted), which checkpoints keep (io/checkpoint.hpp). A factorisation (CPU:
// solve/sparse_cholesky.hpp, CUDA: kernels/device_cholesky.hpp) uses the smallest shift of
// H + tau diag|H| that succeeds, H itself first (modified Newton: the solve is then still a
// descent direction, and the least shifted one is the closest to Newton's). Each try is a
// numeric factorisation, so the search starts where the last factorisation's ended: one decade
// below its step, going down while the shifts succeed and up while they fail (a shift larger
// than one that succeeds succeeds: diag|H| is positive). A run's tangents change little between
// factorisations, so one that needed a shift finds it again in about three tries instead of one
// per decade from the smallest.
#pragma once

#include <stdexcept>
#include <string>

namespace fascia {

constexpr int kShiftSteps = 10;
constexpr double kShifts[kShiftSteps] = {1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1e0, 1e1, 1e2, 1e3};

// The first shifted step tried after a factorisation whose step was `last`.
constexpr int first_shift_step(int last) { return last > 0 ? last - 1 : 0; }

// The first shifted step of a resumed run's next factorisation, the interrupted run's last one
// having been of step `last`: that step itself where the factorisation is held (it is computed
// again, with the same tries), else the one after it.
constexpr int resumed_first_shift_step(int last, bool held) { return held ? (last > 0 ? last : 0) : first_shift_step(last); }

// Refuses (std::invalid_argument) a first shifted step outside 0 .. kShiftSteps - 1.
inline void require_shifted_step(int k) {
  if (k < 0 || k >= kShiftSteps)
    throw std::invalid_argument("shift step " + std::to_string(k) + " outside 0 .. " + std::to_string(kShiftSteps - 1));
}

// The smallest step at which attempt(step) (a numeric factorisation of that shift, -1 unshifted;
// true when it succeeds) succeeds, searched as above from the shifted step `first`; kShiftSteps
// when none does. The last attempt made is at the step returned (after a failed try below it, that
// step is tried again).
template <class Attempt>
int search_shift(int first, Attempt&& attempt) {
  if (attempt(-1)) return -1;
  int step = first;
  if (attempt(step)) {
    for (; step > 0; --step)
      if (!attempt(step - 1)) {
        attempt(step);
        return step;
      }
    return step;
  }
  while (++step < kShiftSteps)
    if (attempt(step)) return step;
  return kShiftSteps;
}

}  // namespace fascia
