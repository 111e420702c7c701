// The configuration of the frames: positions, orientations and velocities.
#pragma once

#include "model/model.hpp"

#include <vector>

namespace fascia {

struct State {
  std::vector<double> positions;     // [N][3] m
  std::vector<double> orientations;  // [N][4] unit quaternions (w, x, y, z)
  std::vector<double> velocities;    // [N][6] linear m/s, angular rad/s (world axes)

  int frame_count() const { return static_cast<int>(positions.size() / 3); }
};

// The rest configuration: frames at rest positions, identity orientations, at rest.
State rest_state(const Model& model);

// q <- q (+) dq for an increment dq [N][6] (DESIGN.md): x_i += dx_i, R_i <- exp([dr_i]x) R_i,
// quaternions renormalised. Rotation increments are skipped when the model locks rotations.
void retract(const Model& model, State& state, const double* dq, double scale = 1.0);

// Rotation matrices R_i of every frame, row-major [N][9].
void rotation_matrices(const State& state, std::vector<double>& out);

}  // namespace fascia
