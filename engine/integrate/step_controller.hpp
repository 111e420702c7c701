// Adaptive steps for backward Euler and for static load paths: a step size controller around the
// step (not SUNDIALS' ARKODE/CVODE; docs/solvers.md says why).
//
// A step of size h is accepted when its nonlinear solve converges and its local error estimate
// is within the tolerance. Backward Euler's local truncation error is (h^2/2) a + O(h^3); with
// a ~ (v_{n+1} - v_n)/h it is estimated per frame as
//
//   e_i = (h/2) |v_{n+1,i} - v_n,i|  +  (h/2) L |w_{n+1,i} - w_n,i|        (m)
//
// on the free DOFs only (prescribed frames follow their motion exactly), L the model's extent
// (the rotation error as the displacement it makes at that distance); e = max_i e_i.
// The next step is h * clamp(0.9 sqrt(tol / e), 0.2, 2) (the error is O(h^2); Hairer, Norsett &
// Wanner, Solving ODEs I, §II.4, eq. 4.13 with q = 1), at most h just after a rejection; a step
// whose nonlinear solve fails is retried with h / 2. Steps stay in [min_dt, max_dt].
//
// Static steps follow the equilibrium path q*(t) of time-dependent motions; each step is an
// equilibrium (no truncation error), so what the tolerance bounds is the increment itself,
// e = max_i (|x_{n+1,i} - x_n,i| + L |log(R_{n+1,i} R_n,i^T)|) (m, free frames), O(h): the next
// step is h * clamp(0.9 tol / e, 0.2, 2). An increment within the tolerance is accepted and the
// next grows (by 1.8 where nothing moved: a hold), a larger one is rejected and retried shorter,
// and a failed solve (inverted elements, no convergence) halves the step; a tolerance larger
// than any increment leaves the failures alone to shorten the steps.
#pragma once

#include "model/model.hpp"
#include "model/state.hpp"

namespace fascia {

struct AdaptiveSettings {
  bool enabled = false;
  double tolerance = 1e-4;  // m, local error per step
  double min_dt = 1e-6;     // s
  double max_dt = 0;        // s; 0: no limit (steps still end on the output times)
};

// What a checkpoint must keep to resume the same sequence of steps.
struct StepControllerState {
  double dt = 0;                  // s, the next step's size before clipping to an output time
  bool after_rejection = false;   // the last attempt was rejected: the next step may not grow
  long accepted = 0;              // steps accepted since the start
  long rejected = 0;              // steps rejected since the start (error or failed solve)
};

// The attempts of an advance to an output time still in progress (Simulation::advance_to()): a
// checkpoint taken between two output times keeps them, so that the row written at the next one
// sums the same attempts as an uninterrupted run's.
struct AdvanceProgress {
  long newton_iterations = 0;
  long cg_iterations = 0;
  long accepted = 0;  // steps accepted since the last output time
  long rejected = 0;  // attempts rejected since the last output time
};

class StepController {
 public:
  // @param error_order the power of h in the error estimate: 2 for backward Euler's local error,
  // 1 for the increments of static steps.
  StepController(const AdaptiveSettings& settings, double first_dt, int error_order = 2);

  // Size of the next attempt from time t, ending exactly on t_target when the remaining time
  // is within the step (the remaining time split into equal steps otherwise).
  double next_step(double t, double t_target) const;
  // After an attempt of size h: converged solve with error estimate `error` (m). Returns
  // whether the step is accepted; updates the next step's size.
  bool update(double h, double error);
  // After an attempt of size h whose nonlinear solve failed: halves the step. Returns false when
  // h was already min_dt (no smaller retry is possible).
  bool failed(double h);

  const StepControllerState& state() const { return m_state; }
  void restore(const StepControllerState& state) { m_state = state; }
  const AdaptiveSettings& settings() const { return m_settings; }

 private:
  double clamp_dt(double dt) const;
  AdaptiveSettings m_settings;
  int m_error_order;
  StepControllerState m_state;
};

// Characteristic length L of the error estimate: the largest extent of the frames' rest
// positions along x, y or z (m; 1 for a single frame).
double model_extent(const Model& model);

// The local error estimate e above, from the states at the start and the end of a step of size
// h (velocities in both), over the model's free DOFs.
double local_error(const Model& model, const State& start, const State& end, double h, double extent);

// The increment estimate e of a static step above, from its start and end states (m).
double static_increment(const Model& model, const State& start, const State& end, double extent);

}  // namespace fascia
