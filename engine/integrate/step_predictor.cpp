#include "integrate/step_predictor.hpp"

#include "core/rotation.hpp"

namespace fascia {

void extrapolated_increments(const State& previous, const State& current, double ratio, std::vector<double>& d) {
  const int n = current.frame_count();
  d.assign(6 * static_cast<size_t>(n), 0.0);
  for (int i = 0; i < n; ++i) {
    store3(&d[6 * i], ratio * (load3(&current.positions[3 * i]) - load3(&previous.positions[3 * i])));
    const Quat rel = load_quat(&current.orientations[4 * i]) * conjugate(load_quat(&previous.orientations[4 * i]));
    store3(&d[6 * i + 3], ratio * quat_log(rel));
  }
}

void predict_static_step(const Model& model, const PathHistory& history, const State& current, double h, State& trial) {
  if (!history.held()) return;
  std::vector<double> d;
  extrapolated_increments(history.previous, current, h / history.dt, d);
  for (size_t k = 0; k < d.size(); ++k)
    if (model.fixed_dofs[k]) d[k] = 0;
  // Fixed DOFs keep trial's values (prescribed motions applied); the rest moves from trial, which
  // holds current's values there.
  retract(model, trial, d.data(), 1.0);
}

void predict_dynamic_step(const Model& model, const PathHistory& history, const State& current, double h,
                          double rayleigh_mass, State& trial) {
  const double scale = h / (1 + rayleigh_mass * h);
  // h a = r ((1 + alpha h_old) v_k - v_{k-1}), r = h / h_old.
  const bool accelerated = history.held();
  const double r = accelerated ? h / history.dt : 0.0, damped = 1 + rayleigh_mass * history.dt;
  std::vector<double> d(current.velocities.size(), 0.0);
  for (size_t k = 0; k < d.size(); ++k) {
    if (model.fixed_dofs[k]) continue;
    const double v = current.velocities[k];
    d[k] = scale * (accelerated ? v + r * (damped * v - history.previous.velocities[k]) : v);
  }
  retract(model, trial, d.data(), 1.0);
}

}  // namespace fascia
