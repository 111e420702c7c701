#include "mechanics/frame_loads.hpp"

#include "core/rotation.hpp"

#include <cmath>

namespace fascia {

FrameLoads::FrameLoads(const Model& model, const ExternalLoads& loads) {
  const int n = model.frame_count();
  m_f.assign(3 * static_cast<size_t>(n), 0.0);
  m_C.assign(9 * static_cast<size_t>(n), 0.0);
  auto add = [&](int i, const Vec3& b, const Vec3& l) {  // a force b at offset l of frame i
    m_f[3 * i] += b.x, m_f[3 * i + 1] += b.y, m_f[3 * i + 2] += b.z;
    const Mat3 lb = outer(l, b);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m_C[9 * i + 3 * r + c] += lb.m[r][c];
  };
  const Vec3 zero{0, 0, 0};
  // Gravity on the samples through eq. (3): b = w rho_s v_s g at offset l of each pair.
  const NeighbourTable& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s) {
    const double m = model.materials[model.samples.materials[s]].density * model.samples.volumes[s];
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
      add(nb.frames[p], (nb.weights[p] * m) * loads.gravity, load3(&nb.rest_offsets[3 * p]));
  }
  for (size_t i = 0; i < model.frame_point_masses.size(); ++i)
    if (model.frame_point_masses[i] != 0) add(static_cast<int>(i), model.frame_point_masses[i] * loads.gravity, zero);
  for (const PointForce& pf : loads.point_forces) add(pf.frame, pf.force, zero);
  for (const MaterialPointForce& mp : loads.material_point_forces)
    for (size_t k = 0; k < mp.frames.size(); ++k)
      add(mp.frames[k], mp.weights[k] * mp.force, load3(&mp.rest_offsets[3 * k]));
}

double FrameLoads::value(const State& state, double s) const {
  double v = 0;
  for (size_t i = 0; i < m_f.size() / 3; ++i)
    v += frame_load_value(load3(&m_f[3 * i]), load_mat3(&m_C[9 * i]), load3(&state.positions[3 * i]),
                          rotation_matrix(load_quat(&state.orientations[4 * i])), s);
  return v;
}

void FrameLoads::add_gradient(const State& state, double s, double* gradient) const {
  for (size_t i = 0; i < m_f.size() / 3; ++i) {
    Vec3 gx, gr;
    frame_load_gradient(load3(&m_f[3 * i]), load_mat3(&m_C[9 * i]),
                        rotation_matrix(load_quat(&state.orientations[4 * i])), s, gx, gr);
    double* g = gradient + 6 * i;
    g[0] += gx.x, g[1] += gx.y, g[2] += gx.z;
    g[3] += gr.x, g[4] += gr.y, g[5] += gr.z;
  }
}

void FrameLoads::add_rotational_blocks(const State& state, double s, double* blocks) const {
  for (size_t i = 0; i < m_f.size() / 3; ++i) {
    const Mat3 K = frame_load_rotational_block(load_mat3(&m_C[9 * i]),
                                               rotation_matrix(load_quat(&state.orientations[4 * i])), s);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) blocks[9 * i + 3 * r + c] += K.m[r][c];
  }
}

double FrameLoads::force_norm(double s) const {
  double n = 0;
  for (double x : m_f) n += x * x;
  return std::abs(s) * std::sqrt(n);
}

}  // namespace fascia
