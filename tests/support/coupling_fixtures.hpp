// Coupled-system fixtures (paper §4.2): a tissue block with a shell on its top face and a rigid
// plate under it, a scene of shells and rigid bodies only (no samples), momenta of a state, and a
// free spinning start.
#pragma once

#include "core/rotation.hpp"
#include "mechanics/rigid_mapping.hpp"
#include "model/assembly.hpp"
#include "support/fixtures.hpp"
#include "support/shell_fixtures.hpp"

#include <catch2/catch.hpp>

namespace fascia::test {

// Block 0.2 x 0.1 x 0.05 m (2 x 2 x 1 hexahedra or their tetrahedra, StVK 10 kPa), a shell on
// its top face sharing its 9 top frames, a rigid plate (2 cm thick, 1000 kg/m^3) under it
// carrying its 9 bottom frames. With fixed_plate the plate's frame is fixed (the block then
// stands on it under gravity).
inline Model coupled_model(CellType cells = CellType::hexahedron, bool fixed_plate = false) {
  const Model block = small_box_model(cells);
  SurfaceMesh top = rectangle_surface(0.2, 0.1, 2, 2);
  for (int k = 0; k < top.vertex_count(); ++k) top.vertices[3 * k + 2] = 0.05;
  ModelBuilder builder;
  const int tissue = builder.add_tissue("tissue", block, SurfaceMesh{});
  const int wall = builder.add_shell("wall", top, ShellProperties{0.004, 5.0e4, 0.35, 1000.0});
  const int bone = builder.add_rigid("bone", box_surface({0, 0, -0.02}, {0.2, 0.1, 0}), 1000.0);
  REQUIRE(builder.share(tissue, wall, 1e-6) == 9);
  REQUIRE(builder.attach(tissue, bone, 1e-6) == 9);
  if (fixed_plate) REQUIRE(builder.fix(bone, [](double, double, double) { return true; }) == 1);
  return builder.build();
}

// No volumetric samples: a 0.2 x 0.1 m shell clamped along x = 0 and a free rigid box.
inline Model shells_and_rigid_model() {
  ModelBuilder builder;
  const int wall = builder.add_shell("wall", rectangle_surface(0.2, 0.1, 4, 2), ShellProperties{0.004, 5.0e4, 0.35, 1000.0});
  builder.add_rigid("bone", box_surface({0, 0, -0.1}, {0.1, 0.05, -0.05}), 1000.0);
  REQUIRE(builder.fix(wall, [](double x, double, double) { return x < 1e-9; }) == 3);
  return builder.build();
}

struct Momentum {
  Vec3 linear, angular;
};

// P = sum m_i v_i, L = sum (x_i x m_i v_i + I_i w_i) with I_i = R_i I_i0 R_i^T, about the origin.
inline Momentum momentum(const Model& model, const State& s) {
  Momentum p{{0, 0, 0}, {0, 0, 0}};
  for (int i = 0; i < model.frame_count(); ++i) {
    const Vec3 v = load3(&s.velocities[6 * i]), w = load3(&s.velocities[6 * i + 3]);
    const Mat3 R = rotation_matrix(load_quat(&s.orientations[4 * i]));
    const Mat3 I = R * load_mat3(&model.frame_inertias[9 * i]) * transpose(R);
    p.linear += model.frame_masses[i] * v;
    p.angular += cross(load3(&s.positions[3 * i]), model.frame_masses[i] * v) + I * w;
  }
  return p;
}

// A free spinning, translating and deforming start: the rigid velocity field (V + W x x) plus a
// deformation velocity.
inline State moving_start(const Model& model, const RigidMapping& mapping) {
  State s = rest_state(model);
  mapping.sync(s);
  const Vec3 V{0.05, -0.02, 0.01}, W{0.5, -1.0, 2.0};
  for (int i = 0; i < model.frame_count(); ++i) {
    const Vec3 x = load3(&s.positions[3 * i]);
    const Vec3 v = V + cross(W, x) + Vec3{0, 0, 0.5 * x.x};
    store3(&s.velocities[6 * i], v);
    store3(&s.velocities[6 * i + 3], W);
  }
  for (int a : mapping.mapped()) {  // attached frames move with their body
    const int b = model.rigid_parents[a];
    const Vec3 r = load3(&s.positions[3 * a]) - load3(&s.positions[3 * b]);
    store3(&s.velocities[6 * a], load3(&s.velocities[6 * b]) + cross(W, r));
  }
  return s;
}

}  // namespace fascia::test
