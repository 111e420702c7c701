// CPU reference of what the device computes, for the kernels tests: one backward-Euler step by
// one Newton iteration with block-Jacobi PCG (the device algorithm, in double on the host, on
// top of fascia::Elasticity), and norm-wise relative differences.
#pragma once

#include "core/rotation.hpp"
#include "elasticity_phases.hpp"
#include "mechanics/elasticity.hpp"
#include "support/fixtures.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace fascia::test {

// ||a - b|| / ||b|| (0 when both vanish).
inline double relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (size_t k = 0; k < b.size(); ++k) {
    num += (a[k] - b[k]) * (a[k] - b[k]);
    den += b[k] * b[k];
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

// A box of tetrahedra (4 neighbours per sample) or hexahedra (8), the x = 0 face fixed, in a
// random deformed state with random velocities.
// With MaterialLaw::hgo each sample has its own material (fibres k1 = 3 E, k2 = 5, dispersion
// 0.1 along a direction that turns from sample to sample), as a fibre field makes them: the
// device reads each sample's fibres through its material index, and the random states stretch
// some samples' fibres and shorten others'. `hgo` picks the law's variant: one family in the
// coupled form, or two at +-0.6 rad about that direction (in its plane with z) in the uncoupled
// form.
enum class HgoVariant { one_family_coupled, two_families_uncoupled };
inline const char* to_string(HgoVariant v) {
  return v == HgoVariant::one_family_coupled ? "one family, coupled" : "two families, uncoupled";
}
inline Model kernels_test_model(CellType type, MaterialLaw law, int nx = 4, int ny = 3, int nz = 2,
                                HgoVariant hgo = HgoVariant::one_family_coupled) {
  Model model = small_box_model(type, law == MaterialLaw::hgo ? MaterialLaw::neo_hookean : law, nx, ny, nz);
  if (law == MaterialLaw::hgo) {
    model.materials.clear();
    const bool two = hgo == HgoVariant::two_families_uncoupled;
    for (int s = 0; s < model.sample_count(); ++s) {
      const Vec3 a{std::cos(0.7 * s), std::sin(0.7 * s), 0.5 * std::cos(1.3 * s)};
      Fibres f{3.0e4, 5.0, 0.1, a};
      if (two) {
        f.families = 2;
        f.angle = 0.6;
        f.plane = Vec3{0, 0, 1};  // never along a: its x, y part has unit length
      }
      model.materials.push_back(make_hgo_material(1.0e4, 0.3, 1000.0, f,
                                                  two ? HgoFormulation::uncoupled : HgoFormulation::coupled));
      model.samples.materials[static_cast<size_t>(s)] = s;
    }
  }
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  return model;
}

// displacement (m): the bound of the positions' perturbation; 0.004 suits the 4 x 3 x 2-cell box
// (cells of 5 cm or more), finer boxes need it below their cell size.
inline State kernels_test_state(const Model& model, unsigned seed, double displacement = 0.004) {
  State s = random_state(model, seed, displacement, 0.2, 0.7);
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double& v : s.velocities) v = 0.05 * u(rng);
  return s;
}

// Gravity on the lumped frame masses, [N][6].
inline std::vector<double> kernels_test_loads(const Model& model) {
  std::vector<double> f(model.dof_count(), 0.0);
  for (int i = 0; i < model.frame_count(); ++i) f[6 * i + 1] = -9.81 * model.frame_masses[i];
  return f;
}

struct ReferenceStep {
  std::vector<double> delta;  // [N][6]
  int iterations = 0;
};

// The device algorithm (device_elasticity.hpp, DeviceBackwardEuler) in double on the CPU.
inline ReferenceStep reference_step(const Model& model, const State& state, double h, int iterations,
                                    const std::vector<double>& external) {
  const int n = model.frame_count(), dofs = model.dof_count();
  Elasticity el(model, 1);
  std::vector<double> g(dofs), blocks(36 * static_cast<size_t>(n));
  el.gradient(state, g.data());
  el.prepare(state);
  el.tangent_diagonal_blocks(blocks.data());
  std::vector<double> J(9 * static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const Mat3 R = rotation_matrix(normalized(load_quat(&state.orientations[4 * i])));
    store_mat3(&J[9 * i], R * load_mat3(&model.frame_inertias[9 * i]) * transpose(R));
  }
  const double inv_h2 = 1.0 / (h * h);
  auto fixed = [&](int j) { return model.fixed_dofs[j] != 0; };
  auto apply = [&](const std::vector<double>& d, std::vector<double>& out) {
    el.apply_tangent(d.data(), out.data());
    for (int i = 0; i < n; ++i) {
      const Vec3 jr = load_mat3(&J[9 * i]) * load3(&d[6 * i + 3]);
      for (int k = 0; k < 3; ++k) out[6 * i + k] += inv_h2 * model.frame_masses[i] * d[6 * i + k];
      out[6 * i + 3] += inv_h2 * jr.x;
      out[6 * i + 4] += inv_h2 * jr.y;
      out[6 * i + 5] += inv_h2 * jr.z;
    }
    for (int j = 0; j < dofs; ++j)
      if (fixed(j)) out[j] = 0;
  };
  std::vector<double> minv(36 * static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    double K[36];
    for (int k = 0; k < 36; ++k) K[k] = blocks[36 * i + k];
    for (int r = 0; r < 3; ++r) {
      K[6 * r + r] += inv_h2 * model.frame_masses[i];
      for (int c = 0; c < 3; ++c) K[6 * (3 + r) + 3 + c] += inv_h2 * J[9 * i + 3 * r + c];
    }
    gpu::block_jacobi_inverse(&model.fixed_dofs[6 * i], K, &minv[36 * i]);
  }
  auto precondition = [&](const std::vector<double>& r, std::vector<double>& z) {
    for (int i = 0; i < n; ++i)
      for (int a = 0; a < 6; ++a) {
        double acc = 0;
        for (int b = 0; b < 6; ++b) acc += minv[36 * i + 6 * a + b] * r[6 * i + b];
        z[6 * i + a] = acc;
      }
  };
  auto dot = [](const std::vector<double>& a, const std::vector<double>& b) {
    double s = 0;
    for (size_t k = 0; k < a.size(); ++k) s += a[k] * b[k];
    return s;
  };
  std::vector<double> x(dofs, 0.0), r(dofs), z(dofs), p(dofs), Ap(dofs);
  for (int i = 0; i < n; ++i) {
    const Vec3 w = load_mat3(&J[9 * i]) * load3(&state.velocities[6 * i + 3]);
    const double mv[6] = {model.frame_masses[i] * state.velocities[6 * i], model.frame_masses[i] * state.velocities[6 * i + 1],
                          model.frame_masses[i] * state.velocities[6 * i + 2], w.x, w.y, w.z};
    for (int k = 0; k < 6; ++k) {
      const int j = 6 * i + k;
      r[j] = fixed(j) ? 0.0 : mv[k] / h - g[j] + (external.empty() ? 0.0 : external[j]);
    }
  }
  precondition(r, z);
  p = z;
  double rz = dot(r, z);
  ReferenceStep out;
  for (int it = 0; it < iterations && rz > 0; ++it) {
    apply(p, Ap);
    const double pAp = dot(p, Ap);
    if (!(pAp > 0)) break;
    const double alpha = rz / pAp;
    for (int j = 0; j < dofs; ++j) {
      x[j] += alpha * p[j];
      r[j] -= alpha * Ap[j];
    }
    precondition(r, z);
    const double rz_new = dot(r, z);
    const double beta = rz_new / rz;
    rz = rz_new;
    ++out.iterations;
    for (int j = 0; j < dofs; ++j) p[j] = z[j] + beta * p[j];
  }
  out.delta = x;
  return out;
}

}  // namespace fascia::test
