#include "mechanics/assembled_tangent.hpp"

#include <Eigen/Dense>

#include <omp.h>

#include <algorithm>
#include <set>

namespace fascia {
namespace {

constexpr int kParallelMin = 256;               // fewer samples: one thread
constexpr long long kChunkValues = 1LL << 22;   // sample-matrix values formed per chunk (32 MiB)

}  // namespace

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
  const int samples = model.sample_count(), frames = model.frame_count();
  // Samples in chunks: the sample matrices H_s = v_s B_s^T D_s B_s [6k x 6k] of a chunk are formed
  // in parallel into m_chunk_values (kept from one assembly to the next), then scattered with each
  // thread owning a contiguous range of column frames and visiting the chunk's samples in order,
  // so every entry sums its samples in sample order: the same bits for any thread count.
#pragma omp parallel num_threads(elasticity.threads()) if (samples > kParallelMin)
  {
    Eigen::Matrix<double, 9, 9, Eigen::RowMajor> D;
    Eigen::Matrix<double, 9, Eigen::Dynamic> B, DB;
    Eigen::Matrix<double, 9, 6, Eigen::RowMajor> Bp;
    const int thread = omp_get_thread_num(), threads = omp_get_num_threads();
    const int own_begin = static_cast<int>(static_cast<long long>(frames) * thread / threads);
    const int own_end = static_cast<int>(static_cast<long long>(frames) * (thread + 1) / threads);
    for (int s0 = 0; s0 < samples;) {
      int s1 = s0;
#pragma omp single
      {
        m_chunk_offsets.assign(1, 0);
        while (s1 < samples && m_chunk_offsets.back() < kChunkValues) {
          const long long k = nb.offsets[s1 + 1] - nb.offsets[s1];
          m_chunk_offsets.push_back(m_chunk_offsets.back() + 36 * k * k);
          ++s1;
        }
        if (m_chunk_values.size() < static_cast<size_t>(m_chunk_offsets.back()))
          m_chunk_values.resize(static_cast<size_t>(m_chunk_offsets.back()));
      }  // implicit barrier: every thread sees the chunk
      s1 = s0 + static_cast<int>(m_chunk_offsets.size()) - 1;
#pragma omp for schedule(dynamic, 16)
      for (int s = s0; s < s1; ++s) {
        const int begin = nb.offsets[s], k = nb.offsets[s + 1] - begin;
        elasticity.material_matrix(s, D.data());
        B.resize(9, 6 * k);
        for (int a = 0; a < k; ++a) {
          elasticity.pair_jacobian(begin + a, Bp.data());
          B.middleCols(6 * a, 6) = Bp;
        }
        // Rows of D are vec(dP[E_k]): the operator acting on vec(dF) is D^T (= D for hyperelastic
        // laws).
        DB.noalias() = D.transpose() * B;
        Eigen::Map<Eigen::MatrixXd> H(m_chunk_values.data() + m_chunk_offsets[s - s0], 6 * k, 6 * k);
        // A coefficient-wise product (inner dimension 9): Eigen's blocked product would start its
        // own OpenMP team here whenever this region runs on one thread, and that team's threads
        // wait for each other by spinning.
        H.noalias() = model.samples.volumes[s] * B.transpose().lazyProduct(DB);
      }  // implicit barrier
      for (int s = s0; s < s1; ++s) {
        const int begin = nb.offsets[s], k = nb.offsets[s + 1] - begin;
        const Eigen::Map<const Eigen::MatrixXd> H(m_chunk_values.data() + m_chunk_offsets[s - s0], 6 * k,
                                                  6 * k);
        const int* slot = &m_pair_slots[m_pair_offsets[s]];
        for (int b = 0; b < k; ++b) {
          const int j = nb.frames[begin + b];
          if (j < own_begin || j >= own_end) continue;
          for (int a = 0; a < k; ++a) {
            const int row_block = slot[a * k + b];
            for (int c = 0; c < 6; ++c) {
              double* column = values + outer[6 * j + c] + 6 * row_block;
              for (int r = 0; r < 6; ++r) column[r] += H(6 * a + r, 6 * b + c);
            }
          }
        }
      }
      s0 = s1;
#pragma omp barrier
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
