// Elastic energy, forces and tangent of the frame model on the CPU (paper §2.2), multithreaded
// with OpenMP. This is the reference the CUDA backend (kernels/) is tested against.
//
// Forces follow the paper's two-pass scheme (§3.2): a pass over samples writes one 6-vector per
// sample-frame pair into a buffer, a pass over frames sums each frame's pairs through the reverse
// table. No atomics; results do not depend on the thread count.
//
// It is the CPU implementation of VolumetricElasticity (mechanics/volumetric_elasticity.hpp).
#pragma once

#include "core/small_math.hpp"
#include "mechanics/frame_sample.hpp"
#include "mechanics/sample_lanes.hpp"
#include "mechanics/volumetric_elasticity.hpp"
#include "material/material.hpp"
#include "model/model.hpp"
#include "model/state.hpp"

#include <vector>

namespace fascia {

class Elasticity final : public VolumetricElasticity {
 public:
  // @param threads OpenMP threads, 0 = the OpenMP default.
  explicit Elasticity(const Model& model, int threads = 0);

  // W = sum_s v_s psi(F_s) in J; +inf if a neo-Hookean sample is inverted.
  double energy(const State& state) override;

  // Energy and its gradient dW/d(theta) at theta = 0 for theta -> W(q (+) theta), [N][6]
  // (N, then N m about world axes). The internal forces of eq. (18) are its negative.
  double gradient(const State& state, double* gradient) override;

  // Precomputes what every tangent product of this state reuses (paper §3, "precompute per
  // Newton iteration"): R_i, a_p = R_i l_p, F_s, P_s and the material cache, and the per-frame
  // rotational geometric blocks. Returns the energy.
  double prepare(const State& state) override;

  // out = K d with K the symmetric Hessian of theta -> W(q (+) theta) at theta = 0: material
  // stiffness (eq. 21-24) plus geometric stiffness (eq. 25-28 and the exponential map's second
  // derivative). d and out are [N][6]. Call prepare() first.
  // With frame_diagonal ([N][10]: t_i, then Q_i row-major, may be null) the product is
  // (K + D) d with D block-diagonal, D_i = diag(t_i I3, Q_i): the inertia and load terms of a
  // time step, added in the same pass over the frames.
  void apply_tangent(const double* d, double* out, const double* frame_diagonal = nullptr) override;

  // The 6x6 diagonal blocks K_ii, [N][36] row-major, for block-Jacobi preconditioning.
  void tangent_diagonal_blocks(double* blocks) override;

  // The 9x9 matrix D_s = d^2 psi / dF^2 of sample s at the prepared state (row k = vec(dP[E_k]),
  // vec row-major), and the pair's 9x6 Jacobian B_p (columns: dF for unit dx and dr, eq. 11).
  void material_matrix(int s, double* D) const;
  void pair_jacobian(int p, double* B) const;
  // The pair's lever M_p = a_p g_p^T + w_p R_i at the prepared state: dF_p = dx g_p^T + [dr]x M_p
  // (mechanics/frame_sample.hpp, pair_lever).
  Mat3 lever(int p) const;

  const Model& model() const override { return m_model; }
  // Itself: the assembled tangent reads this object's prepared state.
  const Elasticity& prepared_reference() override { return *this; }
  int threads() const { return m_threads; }
  // Prepared per-frame rotational geometric blocks [N][9].
  const std::vector<double>& rotational_blocks() const { return m_frame_blocks; }

 private:
  void gather(double* out) const;  // out_i = sum of m_pair over the frame's pairs

  const Model& m_model;
  int m_threads;
  int m_max_pairs = 0;  // largest neighbour count of a sample
  PairTableView m_table;
  std::vector<double> m_rotations;     // [N][9] at the prepared state
  std::vector<double> m_energy_rotations;  // [N][9] energy()'s
  struct Prepared {
    bool valid = false;
    std::vector<double> positions, orientations;  // the prepared state's
    double energy = 0;                            // W there, J
  } m_prepared;
  std::vector<double> m_offsets;       // [P][3] a_p = R_i l_p
  std::vector<double> m_F;             // [S][9]
  std::vector<double> m_P;             // [S][9]
  std::vector<MaterialCache> m_cache;  // [S]
  std::vector<double> m_frame_blocks;  // [N][9]
  std::vector<double> m_pair;          // [P][6] partial contributions
  std::vector<double> m_pair_blocks;   // [P][6] pair rotational geometric blocks (xx yy zz yz xz xy)
  std::vector<double> m_chunk;         // fixed-size chunk sums (deterministic reductions)
  SampleLanes m_lanes;                 // SIMD layout of the tangent product
};

}  // namespace fascia
