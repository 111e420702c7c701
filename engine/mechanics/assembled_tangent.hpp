// The assembled sparse tangent K (6N x 6N) of the elastic energy, for direct solves (CHOLMOD)
// and for checking the matrix-free product.
#pragma once

#include "mechanics/elasticity.hpp"

#include <Eigen/SparseCore>

#include <vector>

namespace fascia {

// Assembles K = sum_s v_s B_s^T D_s B_s + blockdiag(rotational geometric blocks), where B_s
// stacks the 9x6 pair Jacobians of the sample's frames (eq. 11) and D_s = d^2 psi / dF^2, plus
// the entries of the step's other terms (shells, stabilisation, inertia, loads) given as
// triplets. Both triangles are stored. The sparsity pattern (6x6 blocks of frames that share a
// sample or a triplet) is built once per model and set of triplet positions; each assembly only
// scatters values into it.
class TangentAssembler {
 public:
  using Triplets = std::vector<Eigen::Triplet<double>>;
  // The pattern holds the blocks of `others` (the first assembly's other terms) from the start.
  explicit TangentAssembler(const Model& model, const Triplets& others = {});
  // Call elasticity.prepare(state) first. Returns K + T, T the sum of `others` (duplicates summed
  // in their order, as Eigen's setFromTriplets), valid until the next call. Triplets whose 6x6
  // blocks lie outside the pattern widen it (their blocks join it: the pattern is built again).
  const Eigen::SparseMatrix<double>& assemble(const Elasticity& elasticity, const Triplets& others = {});

 private:
  // The pattern of the elastic couplings and the blocks of `extra` ((row frame, column frame)).
  void build_pattern(const std::vector<std::pair<int, int>>& extra);
  // `known` and the blocks of `others`, sorted, each once.
  static std::vector<std::pair<int, int>> blocks_of(std::vector<std::pair<int, int>> known, const Triplets& others);
  // Positions of `others` in the pattern (m_other_*); false if one lies outside it.
  bool locate(const Triplets& others);

  const Model& m_model;
  Eigen::SparseMatrix<double> m_matrix;
  std::vector<std::pair<int, int>> m_extra_blocks;  // the triplets' blocks the pattern was built with
  std::vector<int> m_pair_slots;  // per sample, per (a, b) neighbour pair: block row position k
  std::vector<int> m_pair_offsets;  // [S+1] into m_pair_slots
  // The located triplets: their rows and columns, the distinct positions they reach (in order of
  // first appearance, as value indices) and, per triplet, the index of its position there.
  std::vector<int> m_other_rows, m_other_cols, m_other_positions, m_other_position_of;
  std::vector<double> m_other_sums;  // [distinct positions]
};

// One-off assembly (builds a TangentAssembler).
Eigen::SparseMatrix<double> assemble_tangent(const Elasticity& elasticity);

}  // namespace fascia
