#include "integrate/prescribed_motion.hpp"

#include "core/rotation.hpp"

#include <algorithm>

namespace fascia {

void fix_prescribed_dofs(Model& model, const std::vector<PrescribedMotion>& motions) {
  model.fixed_dofs.resize(model.dof_count(), 0);
  for (const PrescribedMotion& m : motions)
    for (int f : m.frames)
      for (int k = 0; k < (m.rotates ? kFrameDofs : 3); ++k) model.fixed_dofs[kFrameDofs * f + k] = 1;
}

void apply_motions(const Model& model, const std::vector<PrescribedMotion>& motions, double t, State& state) {
  for (const PrescribedMotion& m : motions) {
    const double active = std::max(0.0, std::clamp(t, m.start, m.end) - m.start);
    const Quat q = quat_exp(active * m.angular_velocity);
    const Mat3 Q = rotation_matrix(q);
    for (int f : m.frames) {
      const Vec3 x0 = load3(&model.frame_rest_positions[3 * f]);
      if (!m.rotates) {
        store3(&state.positions[3 * f], x0 + active * m.velocity);
        continue;
      }
      store3(&state.positions[3 * f], m.pivot + active * m.velocity + Q * (x0 - m.pivot));
      store_quat(&state.orientations[4 * f], q);
    }
  }
}

}  // namespace fascia
