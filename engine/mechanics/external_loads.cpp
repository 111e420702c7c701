#include "mechanics/external_loads.hpp"

#include "mechanics/frame_sample.hpp"

#include <cmath>

namespace fascia {
namespace {

Vec3 sample_weight(const Model& model, const ExternalLoads& loads, int s) {
  const double m = model.materials[model.samples.materials[s]].density * model.samples.volumes[s];
  return (loads.scale * m) * loads.gravity;
}

// Gravity acts on every sample with the same direction, so its pair terms sum per frame:
// mu_i = sum_p w_p m_s (kg) and lambda_i = sum_p w_p m_s l_p (kg m), m_s = rho_s v_s, and the
// weight of the samples seen by frame i is the force scale mu_i g applied through the offset
// R_i lambda_i: potential -scale g . (mu_i x_i + R_i lambda_i), eq. (3) summed per frame.
// mu: [N], lambda: [N][3]; O(pairs), no rotation.
void gravity_moments(const Model& model, std::vector<double>& mu, std::vector<double>& lambda) {
  const NeighbourTable& nb = model.neighbours;
  mu.assign(model.frame_count(), 0.0);
  lambda.assign(3 * model.frame_count(), 0.0);
  for (int s = 0; s < model.sample_count(); ++s) {
    const double m = model.materials[model.samples.materials[s]].density * model.samples.volumes[s];
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      const int i = nb.frames[p];
      const double wm = nb.weights[p] * m;
      mu[i] += wm;
      for (int k = 0; k < 3; ++k) lambda[3 * i + k] += wm * nb.rest_offsets[3 * p + k];
    }
  }
}

}  // namespace

double load_potential(const Model& model, const ExternalLoads& loads, const State& state) {
  std::vector<double> R;
  rotation_matrices(state, R);
  std::vector<double> mu, lambda;
  gravity_moments(model, mu, lambda);
  const Vec3 g = loads.scale * loads.gravity;
  double v = 0;
  for (int i = 0; i < model.frame_count(); ++i)
    v -= dot(g, mu[i] * load3(&state.positions[3 * i]) + load_mat3(&R[9 * i]) * load3(&lambda[3 * i]));
  for (const PointForce& f : loads.point_forces)
    v -= loads.scale * dot(f.force, load3(&state.positions[3 * f.frame]));
  for (size_t i = 0; i < model.frame_point_masses.size(); ++i)
    v -= loads.scale * model.frame_point_masses[i] * dot(loads.gravity, load3(&state.positions[3 * i]));
  for (const MaterialPointForce& m : loads.material_point_forces)
    for (size_t k = 0; k < m.frames.size(); ++k) {
      const int i = m.frames[k];
      const Vec3 y = load3(&state.positions[3 * i]) + load_mat3(&R[9 * i]) * load3(&m.rest_offsets[3 * k]);
      v -= loads.scale * m.weights[k] * dot(m.force, y);
    }
  return v;
}

void add_load_gradient(const Model& model, const ExternalLoads& loads, const State& state, double* gradient) {
  std::vector<double> R;
  rotation_matrices(state, R);
  std::vector<double> mu, lambda;
  gravity_moments(model, mu, lambda);
  const Vec3 weight = loads.scale * loads.gravity;
  for (int i = 0; i < model.frame_count(); ++i) {
    // Pair terms [-w b_s, -w (a x b_s)] summed over the frame's pairs.
    const Vec3 t = cross(load_mat3(&R[9 * i]) * load3(&lambda[3 * i]), weight);
    double* g = gradient + 6 * i;
    g[0] -= mu[i] * weight.x, g[1] -= mu[i] * weight.y, g[2] -= mu[i] * weight.z;
    g[3] -= t.x, g[4] -= t.y, g[5] -= t.z;
  }
  for (const PointForce& f : loads.point_forces) {
    double* g = gradient + 6 * f.frame;
    g[0] -= loads.scale * f.force.x, g[1] -= loads.scale * f.force.y, g[2] -= loads.scale * f.force.z;
  }
  for (size_t i = 0; i < model.frame_point_masses.size(); ++i) {
    const Vec3 w = (loads.scale * model.frame_point_masses[i]) * loads.gravity;
    double* g = gradient + 6 * i;
    g[0] -= w.x, g[1] -= w.y, g[2] -= w.z;
  }
  for (const MaterialPointForce& m : loads.material_point_forces)
    for (size_t k = 0; k < m.frames.size(); ++k) {
      const int i = m.frames[k];
      const Vec3 b = (loads.scale * m.weights[k]) * m.force;
      const Vec3 t = cross(load_mat3(&R[9 * i]) * load3(&m.rest_offsets[3 * k]), b);
      double* g = gradient + 6 * i;
      g[0] -= b.x, g[1] -= b.y, g[2] -= b.z;
      g[3] -= t.x, g[4] -= t.y, g[5] -= t.z;
    }
}

void add_load_rotational_blocks(const Model& model, const ExternalLoads& loads, const State& state, double* blocks) {
  std::vector<double> R;
  rotation_matrices(state, R);
  std::vector<double> mu, lambda;
  gravity_moments(model, mu, lambda);
  const Vec3 weight = loads.scale * loads.gravity;
  for (int i = 0; i < model.frame_count(); ++i) {
    // pair_body_force_block is linear in w a: the frame's sum is the block of R_i lambda_i.
    const Mat3 K = pair_body_force_block(weight, load_mat3(&R[9 * i]) * load3(&lambda[3 * i]), 1.0);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) blocks[9 * i + 3 * r + c] += K.m[r][c];
  }
  for (const MaterialPointForce& m : loads.material_point_forces)
    for (size_t k = 0; k < m.frames.size(); ++k) {
      const int i = m.frames[k];
      const Vec3 a = load_mat3(&R[9 * i]) * load3(&m.rest_offsets[3 * k]);
      const Mat3 K = pair_body_force_block(loads.scale * m.force, a, m.weights[k]);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) blocks[9 * i + 3 * r + c] += K.m[r][c];
    }
}

double load_force_norm(const Model& model, const ExternalLoads& loads) {
  std::vector<double> f(3 * model.frame_count(), 0.0);
  const NeighbourTable& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s) {
    const Vec3 b = sample_weight(model, loads, s);
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      double* fi = &f[3 * nb.frames[p]];
      fi[0] += nb.weights[p] * b.x, fi[1] += nb.weights[p] * b.y, fi[2] += nb.weights[p] * b.z;
    }
  }
  for (const MaterialPointForce& m : loads.material_point_forces)
    for (size_t k = 0; k < m.frames.size(); ++k) {
      double* fi = &f[3 * m.frames[k]];
      fi[0] += loads.scale * m.weights[k] * m.force.x, fi[1] += loads.scale * m.weights[k] * m.force.y;
      fi[2] += loads.scale * m.weights[k] * m.force.z;
    }
  for (const PointForce& pf : loads.point_forces) {
    double* fi = &f[3 * pf.frame];
    fi[0] += loads.scale * pf.force.x, fi[1] += loads.scale * pf.force.y, fi[2] += loads.scale * pf.force.z;
  }
  for (size_t i = 0; i < model.frame_point_masses.size(); ++i) {
    const Vec3 w = (loads.scale * model.frame_point_masses[i]) * loads.gravity;
    f[3 * i] += w.x, f[3 * i + 1] += w.y, f[3 * i + 2] += w.z;
  }
  double n = 0;
  for (double x : f) n += x * x;
  return std::sqrt(n);
}

}  // namespace fascia
