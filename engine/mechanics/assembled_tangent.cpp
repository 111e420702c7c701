#include "mechanics/assembled_tangent.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <set>

namespace fascia {

TangentAssembler::TangentAssembler(const Model& model) {
  const int n = model.frame_count();
  const NeighbourTable& nb = model.neighbours;
  // Block adjacency: frames i, j are coupled when a sample has both (the frame itself included).
  std::vector<std::vector<int>> adjacency(n);
  for (int i = 0; i < n; ++i) adjacency[i].push_back(i);
  for (int s = 0; s < model.sample_count(); ++s)
    for (int a = nb.offsets[s]; a < nb.offsets[s + 1]; ++a)
      for (int b = nb.offsets[s]; b < nb.offsets[s + 1]; ++b) adjacency[nb.frames[b]].push_back(nb.frames[a]);
  for (auto& rows : adjacency) {
    std::sort(rows.begin(), rows.end());
    rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
  }
  // Column-major pattern: column 6j+c holds the rows 6i..6i+5 of every neighbour i of j, sorted.
  const int size = 6 * n;
  std::vector<int> outer(size + 1, 0), inner;
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 6; ++c) {
      outer[6 * j + c + 1] = outer[6 * j + c] + 6 * static_cast<int>(adjacency[j].size());
      for (int i : adjacency[j])
        for (int r = 0; r < 6; ++r) inner.push_back(6 * i + r);
    }
  m_matrix.resize(size, size);
  m_matrix.resizeNonZeros(static_cast<Eigen::Index>(inner.size()));
  std::copy(outer.begin(), outer.end(), m_matrix.outerIndexPtr());
  std::copy(inner.begin(), inner.end(), m_matrix.innerIndexPtr());
  std::fill(m_matrix.valuePtr(), m_matrix.valuePtr() + inner.size(), 0.0);
  // Position k of frame i (row block) in column block j, for every (sample, a, b).
  m_pair_offsets.assign(model.sample_count() + 1, 0);
  for (int s = 0; s < model.sample_count(); ++s) {
    const int k = nb.offsets[s + 1] - nb.offsets[s];
    m_pair_offsets[s + 1] = m_pair_offsets[s] + k * k;
    for (int a = nb.offsets[s]; a < nb.offsets[s + 1]; ++a)
      for (int b = nb.offsets[s]; b < nb.offsets[s + 1]; ++b) {
        const auto& rows = adjacency[nb.frames[b]];
        m_pair_slots.push_back(
            static_cast<int>(std::lower_bound(rows.begin(), rows.end(), nb.frames[a]) - rows.begin()));
      }
  }
}

const Eigen::SparseMatrix<double>& TangentAssembler::assemble(const Elasticity& elasticity) {
  const Model& model = elasticity.model();
  const NeighbourTable& nb = model.neighbours;
  double* values = m_matrix.valuePtr();
  const int* outer = m_matrix.outerIndexPtr();
  std::fill(values, values + m_matrix.nonZeros(), 0.0);
  Eigen::Matrix<double, 9, 9, Eigen::RowMajor> D;
  Eigen::Matrix<double, 9, Eigen::Dynamic> B, DB;
  Eigen::Matrix<double, 9, 6, Eigen::RowMajor> Bp;
  Eigen::MatrixXd H;
  // Serial scatter: each (sample, a, b) adds into a distinct block position, but different
  // samples share blocks; one thread keeps the sums in a fixed order.
  for (int s = 0; s < model.sample_count(); ++s) {
    const int begin = nb.offsets[s], k = nb.offsets[s + 1] - begin;
    elasticity.material_matrix(s, D.data());
    B.resize(9, 6 * k);
    for (int a = 0; a < k; ++a) {
      elasticity.pair_jacobian(begin + a, Bp.data());
      B.middleCols(6 * a, 6) = Bp;
    }
    // Rows of D are vec(dP[E_k]): the operator acting on vec(dF) is D^T (= D for hyperelastic laws).
    DB.noalias() = D.transpose() * B;
    H.noalias() = model.samples.volumes[s] * (B.transpose() * DB);
    const int* slot = &m_pair_slots[m_pair_offsets[s]];
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b) {
        const int j = nb.frames[begin + b];
        const int row_block = slot[a * k + b];
        for (int c = 0; c < 6; ++c) {
          double* column = values + outer[6 * j + c] + 6 * row_block;
          for (int r = 0; r < 6; ++r) column[r] += H(6 * a + r, 6 * b + c);
        }
      }
  }
  const std::vector<double>& blocks = elasticity.rotational_blocks();
  for (int i = 0; i < model.frame_count(); ++i) {
    // The diagonal block of frame i sits at position k of its own column block.
    const int* rows_begin = m_matrix.innerIndexPtr() + outer[6 * i];
    const int* rows_end = m_matrix.innerIndexPtr() + outer[6 * i + 1];
    const int k = static_cast<int>(std::lower_bound(rows_begin, rows_end, 6 * i) -
                                   rows_begin) / 6;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) values[outer[6 * i + 3 + c] + 6 * k + 3 + r] += blocks[9 * i + 3 * r + c];
  }
  return m_matrix;
}

Eigen::SparseMatrix<double> assemble_tangent(const Elasticity& elasticity) {
  TangentAssembler assembler(elasticity.model());
  return assembler.assemble(elasticity);
}

}  // namespace fascia
