// A step size controller over a pseudo-time, used for every adaptive step of the engine (not
// SUNDIALS' ARKODE/CVODE; docs/solvers.md says why): the time steps of backward Euler and of
// static load paths (integrate/step_error.hpp gives their error estimates, in m) and the load
// factor's increments inside one static solve (newton.hpp, a difficulty estimate).
//
// An attempt of size h whose nonlinear solve fails is retried with h / 2 (failed()); at min_dt
// nothing smaller is tried. A converged attempt with error estimate e, of order p in h, is
// accepted when e <= tol, and the next step is
//
//   h * clamp(0.9 (tol / e)^(1/p), 0.2, 2)
//
// (Hairer, Norsett & Wanner, Solving ODEs I, §II.4, eq. 4.13), at most h just after a rejection
// or failure; a rejected one is retried with that step (at most 0.9 h). Steps stay in
// [min_dt, max_dt].
//
// - Backward Euler: e = the local error, O(h^2) (p = 2).
// - Static steps along the prescribed motions: each step is an equilibrium, so what the
//   tolerance bounds is how far the path departs from its extrapolation: e = the distance from
//   the predicted start (integrate/step_predictor.hpp), O(h^2) (p = 2); on the first step, with
//   no history to extrapolate, e = the increment, O(h) (p = 1). A hold (e = 0) grows the step by
//   1.8, a failed solve (inverted elements, no convergence) halves it.
// - Load increments of a static solve: e = the Newton iterations the increment took, the
//   tolerance the iteration budget, p = 2: h * clamp(0.9 sqrt(budget / iterations), 0.2, 2), the
//   rule of Crisfield (Non-linear Finite Element Analysis of Solids and Structures, vol. 1,
//   §9.5.1, eq. 9.40) with a desired count of 0.81 x the budget. Every converged increment is
//   within the budget, so accepted: easy ones double, one that used most of the budget shrinks
//   the next before it fails.
#pragma once

namespace fascia {

struct AdaptiveSettings {
  bool enabled = false;
  double tolerance = 1e-4;  // the error estimate's unit (m for time steps), per step
  double min_dt = 1e-6;     // the pseudo-time's unit (s for time steps)
  double max_dt = 0;        // 0: no limit (time steps still end on the output times)
};

// What a checkpoint must keep to resume the same sequence of steps.
struct StepControllerState {
  double dt = 0;                  // the next step's size before clipping to a target (s for time steps)
  bool after_rejection = false;   // the last attempt was rejected: the next step may not grow
  long accepted = 0;              // steps accepted since the start
  long rejected = 0;              // steps rejected since the start (error or failed solve)
};

class StepController {
 public:
  // @param error_order the power of h in the error estimate p (above).
  StepController(const AdaptiveSettings& settings, double first_dt, int error_order = 2);

  // Size of the next attempt from t, ending exactly on t_target when the remainder is within the
  // step (the remainder split into equal steps otherwise).
  double next_step(double t, double t_target) const;
  // After an attempt of size h: converged solve with error estimate `error` (the tolerance's
  // unit) of order error_order in h (0: the constructor's). Returns whether the step is accepted;
  // updates the next step's size.
  bool update(double h, double error, int error_order = 0);
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

}  // namespace fascia
