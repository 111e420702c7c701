#include "model/state.hpp"

#include "core/rotation.hpp"

namespace fascia {

State rest_state(const Model& model) {
  const int n = model.frame_count();
  State s;
  s.positions = model.frame_rest_positions;
  s.orientations.assign(4 * n, 0.0);
  for (int i = 0; i < n; ++i) s.orientations[4 * i] = 1.0;
  s.velocities.assign(6 * n, 0.0);
  return s;
}

void retract(const Model& model, State& state, const double* dq, double scale) {
  const int n = state.frame_count();
  for (int i = 0; i < n; ++i) {
    const double* d = dq + kFrameDofs * i;
    for (int k = 0; k < 3; ++k) state.positions[3 * i + k] += scale * d[k];
    if (model.rotations_locked) continue;
    const Vec3 dr{scale * d[3], scale * d[4], scale * d[5]};
    store_quat(&state.orientations[4 * i], apply_increment(load_quat(&state.orientations[4 * i]), dr));
  }
}

void rotation_matrices(const State& state, std::vector<double>& out) {
  const int n = state.frame_count();
  out.resize(9 * n);
  for (int i = 0; i < n; ++i) store_mat3(&out[9 * i], rotation_matrix(load_quat(&state.orientations[4 * i])));
}

}  // namespace fascia
