#include "solve/step_controller.hpp"

#include <algorithm>
#include <cmath>

namespace fascia {

StepController::StepController(const AdaptiveSettings& settings, double first_dt, int error_order)
    : m_settings(settings), m_error_order(error_order) {
  m_state.dt = clamp_dt(first_dt);
}

double StepController::clamp_dt(double dt) const {
  if (m_settings.max_dt > 0) dt = std::min(dt, m_settings.max_dt);
  return std::max(dt, m_settings.min_dt);
}

double StepController::next_step(double t, double t_target) const {
  const double remaining = t_target - t;
  if (remaining <= m_state.dt) return remaining;
  // Equal steps to the target, none larger than dt: no sliver of a step before an output time.
  const double n = std::ceil(remaining / m_state.dt - 1e-9);
  return remaining / n;
}

bool StepController::update(double h, double error, int error_order) {
  const int p = error_order > 0 ? error_order : m_error_order;
  // An error of zero grows the step as an error of tol / 4 (order 2) or tol / 2 (order 1) does:
  // by 0.9 x 2 = 1.8.
  const double ratio = error > 0 ? m_settings.tolerance / error : (p == 2 ? 4.0 : 2.0);
  const double factor = std::clamp(0.9 * (p == 2 ? std::sqrt(ratio) : ratio), 0.2, 2.0);
  if (error <= m_settings.tolerance) {
    ++m_state.accepted;
    // A step shortened to land on an output time does not shrink the size the controller has
    // reached; after a rejection the size does not grow on the first accepted step.
    const double grown = m_state.after_rejection ? std::min(factor, 1.0) * h : factor * h;
    m_state.dt = clamp_dt(h < m_state.dt && factor >= 1.0 ? std::max(grown, m_state.dt) : grown);
    m_state.after_rejection = false;
    return true;
  }
  ++m_state.rejected;
  m_state.after_rejection = true;
  if (h <= m_settings.min_dt) {
    // Nothing smaller to try: accept at min_dt rather than stop (the error bound is then not met,
    // which the dt observable shows).
    --m_state.rejected;
    ++m_state.accepted;
    m_state.dt = m_settings.min_dt;
    return true;
  }
  m_state.dt = clamp_dt(std::min(factor, 0.9) * h);
  return false;
}

bool StepController::failed(double h) {
  ++m_state.rejected;
  m_state.after_rejection = true;
  if (h <= m_settings.min_dt) return false;
  m_state.dt = clamp_dt(0.5 * h);
  return true;
}

}  // namespace fascia
