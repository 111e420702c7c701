// Prescribed motion of frames (a tool pulling tissue, a bone flexing about a joint): the selected
// frames' DOFs leave the unknowns and are placed on a rigid path at every step.
//
// With a = clamp(t, start, end) - start the active time (s), the rest position x0 of a frame
// (rest orientations are identity) moves to
//   x(t) = pivot + velocity a + Q(a) (x0 - pivot),   R(t) = Q(a),   Q(a) = exp([angular_velocity a]x)
// i.e. a rotation about the pivot at constant angular velocity (world axes) combined with a
// translation of the whole (pivot included) at constant velocity. Without rotation only the
// translations are prescribed (x(t) = x0 + velocity a) and the frames' rotations stay free; with
// rotation all six DOFs are prescribed. Frames attached to a moved rigid body follow it through
// the rigid mapping, so they undergo exactly the same rigid motion.
#pragma once

#include "model/state.hpp"

#include <limits>
#include <vector>

namespace fascia {

struct PrescribedMotion {
  std::vector<int> frames;
  Vec3 velocity{0, 0, 0};          // m/s
  bool rotates = false;            // angular_velocity and pivot apply, rotations are prescribed
  Vec3 angular_velocity{0, 0, 0};  // rad/s, world axes
  Vec3 pivot{0, 0, 0};             // m, at rest (moves with velocity)
  double start = 0;                // s
  double end = std::numeric_limits<double>::infinity();  // s
};

// Marks the prescribed DOFs of every motion fixed in model.fixed_dofs (sized to the DOF count).
void fix_prescribed_dofs(Model& model, const std::vector<PrescribedMotion>& motions);

// Places every moved frame on its path at time t (s): positions, and orientations when rotating.
void apply_motions(const Model& model, const std::vector<PrescribedMotion>& motions, double t, State& state);

}  // namespace fascia
