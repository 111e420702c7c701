#include "mechanics/frame_loads.hpp"

namespace fascia {

void frame_load_moments(const Model& model, const ExternalLoads& loads, std::vector<double>& f,
                        std::vector<double>& C) {
  const int n = model.frame_count();
  f.assign(3 * static_cast<size_t>(n), 0.0);
  C.assign(9 * static_cast<size_t>(n), 0.0);
  auto add = [&](int i, const Vec3& b, const Vec3& l) {  // a force b at offset l of frame i
    f[3 * i] += b.x, f[3 * i + 1] += b.y, f[3 * i + 2] += b.z;
    const Mat3 lb = outer(l, b);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) C[9 * i + 3 * r + c] += lb.m[r][c];
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

}  // namespace fascia
