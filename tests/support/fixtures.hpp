// Shared test fixtures: small models in random deformed states.
#pragma once

#include "core/rotation.hpp"
#include "discretise/mesh_based.hpp"
#include "model/state.hpp"

#include <random>

namespace fascia::test {

// A small box model (hexahedra or tetrahedra) with given material law.
inline Model small_box_model(CellType type, MaterialLaw law = MaterialLaw::stvk, int nx = 2, int ny = 2, int nz = 1) {
  const Material mat = make_material(law, 1.0e4, 0.3, 1000.0);
  const VolumeMesh mesh = type == CellType::hexahedron ? box_hex_mesh({0, 0, 0}, {0.2, 0.1, 0.05}, nx, ny, nz)
                                                       : box_tet_mesh({0, 0, 0}, {0.2, 0.1, 0.05}, nx, ny, nz);
  return build_mesh_model(mesh, mat, {});
}

// A random state near rest: positions perturbed by up to `displacement` (m), orientations
// rotated by random rotation vectors of norm up to `rotation` (rad), plus an optional global
// rotation so that large rotations are exercised.
inline State random_state(const Model& model, unsigned seed, double displacement, double rotation,
                          double global_rotation = 0.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  State s = rest_state(model);
  std::vector<double> dq(model.dof_count(), 0.0);
  for (int i = 0; i < model.frame_count(); ++i) {
    for (int k = 0; k < 3; ++k) dq[6 * i + k] = displacement * u(rng);
    for (int k = 3; k < 6; ++k) dq[6 * i + k] = rotation * u(rng) / std::sqrt(3.0);
  }
  retract(model, s, dq.data());
  if (global_rotation != 0.0) {
    const Vec3 axis = Vec3{0.3, -0.5, 0.8};
    const Vec3 r = (global_rotation / norm(axis)) * axis;
    const Mat3 Q = rotation_matrix(quat_exp(r));
    for (int i = 0; i < model.frame_count(); ++i) {
      store3(&s.positions[3 * i], Q * load3(&s.positions[3 * i]));
      store_quat(&s.orientations[4 * i], normalized(quat_exp(r) * load_quat(&s.orientations[4 * i])));
    }
  }
  return s;
}

}  // namespace fascia::test
