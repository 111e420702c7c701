#include "mechanics/assembled_tangent.hpp"

#include "core/target_clones.hpp"

#include <omp.h>

#include <algorithm>
#include <vector>

namespace fascia {
namespace {

constexpr int kParallelMin = 256;               // fewer samples: one thread

// A pair's 9 x 6 matrix W_b = v D^T B_b is stored as 9 rows of kRowStride doubles, its 6
// columns and 2 zeros: two 4-double vectors per row for the block products below.
constexpr int kPairRows = 9;
constexpr int kRowStride = 8;

struct SamplePairs {
  std::vector<Mat3> levers;    // [k] the pairs' levers M (elasticity.lever)
  std::vector<Vec3> gradients;  // [k] the pairs' weight gradients g, 1/m
};

// Adds a sample's blocks K_ab = B_a^T W_b (a <= b, a and b its k neighbour pairs) to the matrix:
// in column frame j_b where owned[b], and transposed in column frame j_a where owned[a] (a != b).
// D: [81] the sample's material matrix d^2 psi / dF^2 (row e: vec(dP[E_e])); v: its volume, m^3;
// frames: [k] its neighbour frames; slot: [k k] block row positions (m_pair_slots); W: scratch of
// kPairRows kRowStride k doubles. The arithmetic of a block does not depend on the owner, so a
// block whose frames have different owners adds the same bits in both places.
FASCIA_CLONES void add_sample_blocks(const double* D, double v, const SamplePairs& pairs, int k, const char* owned,
                                     const int* frames, const int* slot, double* W, const int* outer,
                                     double* values) {
  for (int b = 0; b < k; ++b) {
    double* w = &W[kPairRows * kRowStride * b];
    for (int c = 0; c < 6; ++c) {
      // dF of the unit increment c (eq. 11), then dP = D^T vec(dF): rows of D are vec(dP[E_e]).
      Vec3 dx{0, 0, 0}, dr{0, 0, 0};
      (c < 3 ? dx : dr) = Vec3{c % 3 == 0 ? 1.0 : 0.0, c % 3 == 1 ? 1.0 : 0.0, c % 3 == 2 ? 1.0 : 0.0};
      const Mat3 dF = pair_lever_differential(dx, dr, pairs.gradients[b], pairs.levers[b]);
      double out[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
      for (int e = 0; e < 9; ++e) {
        const double f = v * dF.m[e / 3][e % 3];
        if (f == 0) continue;
        for (int r = 0; r < 9; ++r) out[r] += f * D[9 * e + r];
      }
      for (int e = 0; e < 9; ++e) w[kRowStride * e + c] = out[e];
    }
    for (int e = 0; e < 9; ++e) w[kRowStride * e + 6] = w[kRowStride * e + 7] = 0;
  }
  for (int b = 0; b < k; ++b) {
    const double* w = &W[kPairRows * kRowStride * b];
    for (int a = 0; a <= b; ++a) {
      if (!owned[a] && !owned[b]) continue;
      // K_ab = B_a^T W_b, row by row across the 6 (+ 2) columns c of W_b, P_c = W_b[:, c] as
      // 3 x 3: rows 0-2 are P_c g (the force part), rows 3-5 axial(M P_c^T) (the torque part).
      const Vec3& g = pairs.gradients[a];
      const Mat3& M = pairs.levers[a];
      alignas(32) double K[6][kRowStride];
      for (int r = 0; r < 3; ++r) {
        const double* p0 = w + kRowStride * (3 * r);
#pragma omp simd
        for (int c = 0; c < kRowStride; ++c)
          K[r][c] = p0[c] * g.x + p0[kRowStride + c] * g.y + p0[2 * kRowStride + c] * g.z;
      }
#pragma omp simd
      for (int c = 0; c < kRowStride; ++c) K[3][c] = K[4][c] = K[5][c] = 0;
      for (int j = 0; j < 3; ++j) {
        const double* p0 = w + kRowStride * j;        // P[0][j] of each column
        const double* p1 = w + kRowStride * (3 + j);  // P[1][j]
        const double* p2 = w + kRowStride * (6 + j);  // P[2][j]
        const double m0 = M.m[0][j], m1 = M.m[1][j], m2 = M.m[2][j];
#pragma omp simd
        for (int c = 0; c < kRowStride; ++c) {
          K[3][c] += m1 * p2[c] - m2 * p1[c];
          K[4][c] += m2 * p0[c] - m0 * p2[c];
          K[5][c] += m0 * p1[c] - m1 * p0[c];
        }
      }
      if (a == b)  // a diagonal block: its upper triangle mirrored, so that K = K^T bitwise
        for (int c = 0; c < 6; ++c)
          for (int r = 0; r < c; ++r) K[r][c] = K[c][r];
      if (owned[b]) {
        const int row_block = slot[a * k + b];
        for (int c = 0; c < 6; ++c) {
          double* column = values + outer[6 * frames[b] + c] + 6 * row_block;
          for (int r = 0; r < 6; ++r) column[r] += K[r][c];
        }
      }
      if (owned[a] && a != b) {
        const int row_block = slot[b * k + a];
        for (int r = 0; r < 6; ++r) {
          double* column = values + outer[6 * frames[a] + r] + 6 * row_block;
#pragma omp simd
          for (int c = 0; c < 6; ++c) column[c] += K[r][c];
        }
      }
    }
  }
}

}  // namespace

TangentAssembler::TangentAssembler(const Model& model, const Triplets& others) : m_model(model) {
  build_pattern(blocks_of({}, others));
}

std::vector<std::pair<int, int>> TangentAssembler::blocks_of(std::vector<std::pair<int, int>> known,
                                                             const Triplets& others) {
  for (const auto& t : others) known.emplace_back(t.row() / 6, t.col() / 6);
  std::sort(known.begin(), known.end());
  known.erase(std::unique(known.begin(), known.end()), known.end());
  return known;
}

void TangentAssembler::build_pattern(const std::vector<std::pair<int, int>>& extra) {
  const Model& model = m_model;
  const int n = model.frame_count(), samples = model.sample_count();
  const NeighbourTable& nb = model.neighbours;
  const ReverseTable& rev = model.reverse;
  m_extra_blocks = extra;
  // Extra rows per column block, both ways round (the pattern stays symmetric).
  std::vector<std::vector<int>> extra_rows(n);
  for (const auto& [i, j] : extra) {
    extra_rows[j].push_back(i);
    extra_rows[i].push_back(j);
  }
  // Block adjacency: frames i, j are coupled when a sample has both (the frame itself included);
  // the rows of column block j are the frames of j's samples, each marked once, sorted.
  std::vector<std::vector<int>> adjacency(n);
#pragma omp parallel if (samples > kParallelMin)
  {
    std::vector<int> seen(n, -1);
#pragma omp for schedule(dynamic, 16)
    for (int j = 0; j < n; ++j) {
      std::vector<int>& rows = adjacency[j];
      seen[j] = j;
      rows.push_back(j);
      for (int k = rev.offsets[j]; k < rev.offsets[j + 1]; ++k) {
        const int s = rev.pair_samples[rev.pairs[k]];
        for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
          if (seen[nb.frames[p]] != j) {
            seen[nb.frames[p]] = j;
            rows.push_back(nb.frames[p]);
          }
      }
      for (int i : extra_rows[j])
        if (seen[i] != j) {
          seen[i] = j;
          rows.push_back(i);
        }
      std::sort(rows.begin(), rows.end());
    }
  }
  // Column-major pattern: column 6j+c holds the rows 6i..6i+5 of every neighbour i of j, sorted.
  const int size = 6 * n;
  std::vector<int> outer(size + 1, 0);
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 6; ++c) outer[6 * j + c + 1] = outer[6 * j + c] + 6 * static_cast<int>(adjacency[j].size());
  m_matrix.resize(size, size);
  m_matrix.resizeNonZeros(static_cast<Eigen::Index>(outer.back()));
  std::copy(outer.begin(), outer.end(), m_matrix.outerIndexPtr());
  int* inner = m_matrix.innerIndexPtr();
#pragma omp parallel for schedule(dynamic, 16) if (samples > kParallelMin)
  for (int j = 0; j < n; ++j)
    for (int c = 0; c < 6; ++c) {
      int at = outer[6 * j + c];
      for (int i : adjacency[j])
        for (int r = 0; r < 6; ++r) inner[at++] = 6 * i + r;
    }
  std::fill(m_matrix.valuePtr(), m_matrix.valuePtr() + outer.back(), 0.0);
  m_other_rows.clear();
  m_other_cols.clear();
  // Position k of frame i (row block) in column block j, for every (sample, a, b).
  m_pair_offsets.assign(samples + 1, 0);
  for (int s = 0; s < samples; ++s) {
    const int k = nb.offsets[s + 1] - nb.offsets[s];
    m_pair_offsets[s + 1] = m_pair_offsets[s] + k * k;
  }
  m_pair_slots.resize(static_cast<size_t>(m_pair_offsets.back()));
  // Column block by column block: the positions of its rows in a frame-indexed table, read for
  // every pair (s, b) of the column's frame and every a of s (slot a k + b of s).
#pragma omp parallel if (samples > kParallelMin)
  {
    std::vector<int> position(n, -1);
#pragma omp for schedule(dynamic, 16)
    for (int j = 0; j < n; ++j) {
      const std::vector<int>& rows = adjacency[j];
      for (int q = 0; q < static_cast<int>(rows.size()); ++q) position[rows[q]] = q;
      for (int r = rev.offsets[j]; r < rev.offsets[j + 1]; ++r) {
        const int p = rev.pairs[r], s = rev.pair_samples[p];
        const int begin = nb.offsets[s], k = nb.offsets[s + 1] - begin, b = p - begin;
        int* slot = &m_pair_slots[m_pair_offsets[s]];
        for (int a = 0; a < k; ++a) slot[a * k + b] = position[nb.frames[begin + a]];
      }
    }
  }
}

bool TangentAssembler::locate(const Triplets& others) {
  const std::size_t count = others.size();
  bool same = m_other_rows.size() == count;
  for (std::size_t k = 0; same && k < count; ++k)
    same = others[k].row() == m_other_rows[k] && others[k].col() == m_other_cols[k];
  if (same) return true;
  m_other_rows.resize(count);
  m_other_cols.resize(count);
  m_other_position_of.resize(count);
  m_other_positions.clear();
  std::vector<int> distinct(static_cast<std::size_t>(m_matrix.nonZeros()), -1);  // position -> its index
  const int* outer = m_matrix.outerIndexPtr();
  const int* inner = m_matrix.innerIndexPtr();
  bool inside = true;
  for (std::size_t k = 0; k < count; ++k) {
    const int r = others[k].row(), c = others[k].col();
    m_other_rows[k] = r;
    m_other_cols[k] = c;
    const int* at = std::lower_bound(inner + outer[c], inner + outer[c + 1], r);
    if (at == inner + outer[c + 1] || *at != r) {
      inside = false;
      continue;
    }
    const int position = static_cast<int>(at - inner);
    if (distinct[position] < 0) {
      distinct[position] = static_cast<int>(m_other_positions.size());
      m_other_positions.push_back(position);
    }
    m_other_position_of[k] = distinct[position];
  }
  if (!inside) m_other_rows.clear();  // located again once the pattern holds them
  return inside;
}

const Eigen::SparseMatrix<double>& TangentAssembler::assemble(const Elasticity& elasticity, const Triplets& others) {
  if (!locate(others)) {
    build_pattern(blocks_of(m_extra_blocks, others));
    locate(others);
  }
  const Model& model = elasticity.model();
  const NeighbourTable& nb = model.neighbours;
  double* values = m_matrix.valuePtr();
  const int* outer = m_matrix.outerIndexPtr();
  std::fill(values, values + m_matrix.nonZeros(), 0.0);
  const int samples = model.sample_count(), frames = model.frame_count();
  // Each thread owns a contiguous range of column frames and visits every sample in order, so
  // each entry sums its samples in sample order: the same bits for any thread count. A sample's
  // block (a, b) = v B_a^T D B_b is formed for a <= b only and stored in column frame j_b and,
  // transposed, in column frame j_a (D is symmetric for a hyperelastic law): by the owner of
  // each, with the same arithmetic, so a block whose two frames have different owners is formed
  // twice.
#pragma omp parallel num_threads(elasticity.threads()) if (samples > kParallelMin)
  {
    const int thread = omp_get_thread_num(), threads = omp_get_num_threads();
    const int own_begin = static_cast<int>(static_cast<long long>(frames) * thread / threads);
    const int own_end = static_cast<int>(static_cast<long long>(frames) * (thread + 1) / threads);
    SamplePairs pairs;
    double D[81];
    std::vector<double> W;
    std::vector<char> owned;
    for (int s = 0; s < samples; ++s) {
      const int begin = nb.offsets[s], k = nb.offsets[s + 1] - begin;
      owned.assign(k, 0);
      bool any = false;
      for (int a = 0; a < k; ++a) {
        const int j = nb.frames[begin + a];
        owned[a] = j >= own_begin && j < own_end;
        any = any || owned[a];
      }
      if (!any) continue;
      elasticity.material_matrix(s, D);
      pairs.levers.resize(k);
      pairs.gradients.resize(k);
      for (int b = 0; b < k; ++b) {
        pairs.levers[b] = elasticity.lever(begin + b);
        pairs.gradients[b] = load3(&nb.weight_gradients[3 * (begin + b)]);
      }
      W.resize(static_cast<size_t>(kPairRows) * kRowStride * k);
      add_sample_blocks(D, model.samples.volumes[s], pairs, k, owned.data(), &nb.frames[begin],
                        &m_pair_slots[m_pair_offsets[s]], W.data(), outer, values);
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
  // The other terms: each position's triplets summed in their order, then added to K's entry.
  m_other_sums.assign(m_other_positions.size(), 0.0);
  for (std::size_t k = 0; k < others.size(); ++k) m_other_sums[m_other_position_of[k]] += others[k].value();
  for (std::size_t u = 0; u < m_other_positions.size(); ++u) values[m_other_positions[u]] += m_other_sums[u];
  return m_matrix;
}

Eigen::SparseMatrix<double> assemble_tangent(const Elasticity& elasticity) {
  TangentAssembler assembler(elasticity.model());
  return assembler.assemble(elasticity);
}

}  // namespace fascia
