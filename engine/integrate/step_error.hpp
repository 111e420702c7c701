// Error estimates of adaptive time steps (solve/step_controller.hpp sizes the steps from them)
// and the counts of an advance to an output time.
//
// Backward Euler's local truncation error is (h^2/2) a + O(h^3); with a ~ (v_{n+1} - v_n)/h it
// is estimated per frame as
//
//   e_i = (h/2) |v_{n+1,i} - v_n,i|  +  (h/2) L |w_{n+1,i} - w_n,i|        (m)
//
// on the free DOFs only (prescribed frames follow their motion exactly), L the model's extent
// (the rotation error as the displacement it makes at that distance); e = max_i e_i, O(h^2).
//
// Static steps follow the equilibrium path q*(t) of time-dependent motions. Their estimate is the
// distance of the equilibrium q_{n+1} from the step's predicted start p_{n+1}, the secant through
// the last two equilibria (step_predictor.hpp),
//   e = max_i (|x_{n+1,i} - p_i| + L |log(R_{n+1,i} R_{p,i}^T)|)      (m, free frames),
// O(h (h + h_old)) on a smooth path: how far the path bends away from its piecewise-linear
// interpolation. The first step has no secant; its estimate is the increment, the same distance
// from q_n, O(h).
#pragma once

#include "model/model.hpp"
#include "model/state.hpp"
#include "solve/step_controller.hpp"

namespace fascia {

// The attempts of an advance to an output time still in progress (Simulation::advance_to()): a
// checkpoint taken between two output times keeps them, so that the row written at the next one
// sums the same attempts as an uninterrupted run's.
struct AdvanceProgress {
  long newton_iterations = 0;
  long cg_iterations = 0;
  long accepted = 0;  // steps accepted since the last output time
  long rejected = 0;  // attempts rejected since the last output time
};

// Characteristic length L of the error estimate: the largest extent of the frames' rest
// positions along x, y or z (m; 1 for a single frame).
double model_extent(const Model& model);

// The local error estimate e above, from the states at the start and the end of a step of size
// h (velocities in both), over the model's free DOFs.
double local_error(const Model& model, const State& start, const State& end, double h, double extent);

// The distance e above between two states of a static step (m, free frames): from the predicted
// start, or from the step's start for the increment.
double static_increment(const Model& model, const State& start, const State& end, double extent);

}  // namespace fascia
