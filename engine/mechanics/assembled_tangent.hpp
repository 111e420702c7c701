// The assembled sparse tangent K (6N x 6N) of the elastic energy, for direct solves (CHOLMOD)
// and for checking the matrix-free product.
#pragma once

#include "mechanics/elasticity.hpp"

#include <Eigen/SparseCore>

#include <vector>

namespace fascia {

// Assembles K = sum_s v_s B_s^T D_s B_s + blockdiag(rotational geometric blocks), where B_s
// stacks the 9x6 pair Jacobians of the sample's frames (eq. 11) and D_s = d^2 psi / dF^2. Both
// triangles are stored. The sparsity pattern (6x6 blocks of frames that share a sample) is built
// once per model; each assembly only scatters values into it.
class TangentAssembler {
 public:
  explicit TangentAssembler(const Model& model);
  // Call elasticity.prepare(state) first. Returns the matrix (valid until the next call).
  const Eigen::SparseMatrix<double>& assemble(const Elasticity& elasticity);

 private:
  Eigen::SparseMatrix<double> m_matrix;
  std::vector<int> m_pair_slots;  // per sample, per (a, b) neighbour pair: block row position k
  std::vector<int> m_pair_offsets;  // [S+1] into m_pair_slots
};

// One-off assembly (builds a TangentAssembler).
Eigen::SparseMatrix<double> assemble_tangent(const Elasticity& elasticity);

}  // namespace fascia
