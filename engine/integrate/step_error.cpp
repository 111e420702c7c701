#include "integrate/step_error.hpp"

#include "core/rotation.hpp"

#include <algorithm>
#include <cmath>

namespace fascia {

double model_extent(const Model& model) {
  const int n = model.frame_count();
  if (n < 2) return 1.0;
  double extent = 0;
  for (int k = 0; k < 3; ++k) {
    double lo = model.frame_rest_positions[static_cast<std::size_t>(k)], hi = lo;
    for (int i = 1; i < n; ++i) {
      const double x = model.frame_rest_positions[3 * static_cast<std::size_t>(i) + k];
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    extent = std::max(extent, hi - lo);
  }
  return extent > 0 ? extent : 1.0;
}

double local_error(const Model& model, const State& start, const State& end, double h, double extent) {
  double error = 0;
  for (int i = 0; i < model.frame_count(); ++i) {
    double dv = 0, dw = 0;
    for (int k = 0; k < 3; ++k) {
      const std::size_t t = 6 * static_cast<std::size_t>(i) + k, r = t + 3;
      if (!model.fixed_dofs[t]) dv += std::pow(end.velocities[t] - start.velocities[t], 2);
      if (!model.fixed_dofs[r]) dw += std::pow(end.velocities[r] - start.velocities[r], 2);
    }
    error = std::max(error, 0.5 * h * (std::sqrt(dv) + extent * std::sqrt(dw)));
  }
  return error;
}

double static_increment(const Model& model, const State& start, const State& end, double extent) {
  double increment = 0;
  for (int i = 0; i < model.frame_count(); ++i) {
    double dx = 0;
    for (int k = 0; k < 3; ++k)
      if (!model.fixed_dofs[6 * static_cast<std::size_t>(i) + k])
        dx += std::pow(end.positions[3 * i + k] - start.positions[3 * i + k], 2);
    double dr = 0;
    if (!model.fixed_dofs[6 * static_cast<std::size_t>(i) + 3]) {
      const Quat rel = load_quat(&end.orientations[4 * i]) * conjugate(load_quat(&start.orientations[4 * i]));
      dr = norm(quat_log(rel));
    }
    increment = std::max(increment, std::sqrt(dx) + extent * dr);
  }
  return increment;
}

}  // namespace fascia
