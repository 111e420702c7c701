#include "mechanics/elasticity.hpp"

#include "core/target_clones.hpp"

#include "mechanics/frame_sample.hpp"

#include <cmath>
#include <omp.h>

namespace fascia {
namespace {

// Reductions sum fixed chunks of samples, then the chunk sums in order: the result does not
// depend on the number of threads.
constexpr int kChunk = 1024;
// Below this many items a loop runs on one thread: a parallel region costs more than it saves.
constexpr int kParallelMin = 1024;

// F of sample s (eq. 8, as sample_deformation_gradient) and the rotated offsets a_p = R_i l_p of
// its pairs, a[3 k ..] for the k-th pair, computed once for F and for the pair shares. a is
// written and read a double at a time: a Vec3 copied whole is stored as two doubles and reloaded
// as one 16-byte vector, which the CPU cannot forward from the two stores (a stall per pair).
Mat3 deformation_gradient_and_offsets(const NeighbourTable& nb, int s, const double* x, const double* R, double* a) {
  Mat3 F = zero3();
  for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
    const int i = nb.frames[p];
    const Mat3 Ri = load_mat3(R + 9 * i);
    const Vec3 ap = Ri * load3(&nb.rest_offsets[3 * p]);
    store3(a + 3 * (p - nb.offsets[s]), ap);
    F += outer(load3(x + 3 * i) + ap, load3(&nb.weight_gradients[3 * p])) + nb.weights[p] * Ri;
  }
  return F;
}

// Where prepare() writes: per sample F, P [S][9] and the material cache [S]; per pair a_p [P][3],
// the pair's share of the gradient [P][6] and its rotational geometric block [P][6]; the lanes.
struct PreparedArrays {
  double* F;
  double* P;
  MaterialCache* cache;
  double* offsets;
  double* pair;
  double* pair_blocks;
  SampleLanes* lanes;
};

// Prepares sample s at positions x [N][3] and rotations R [N][9] (a: scratch of its pair count):
// F, P and the cache, the lanes' sample and levers, and per pair a_p, the share of the gradient
// and the rotational geometric block. Returns v psi, J. The Mat3 arithmetic is inlined into a
// clone for AVX2 + FMA (core/target_clones.hpp).
FASCIA_CLONES __attribute__((flatten)) double prepare_sample(const Model& model, int s, const double* x,
                                                             const double* R, double* a, const PreparedArrays& out) {
  const NeighbourTable& nb = model.neighbours;
  const Mat3 F = deformation_gradient_and_offsets(nb, s, x, R, a);
  const Material& mat = model.materials[model.samples.materials[s]];
  const double v = model.samples.volumes[s];
  double psi = 0;
  const Mat3 P = energy_and_first_piola(mat, F, out.cache[s], psi);
  store_mat3(&out.F[9 * s], F);
  store_mat3(&out.P[9 * s], P);
  out.lanes->set_sample(s, mat, v, F, out.cache[s]);
  const Mat3 vP = v * P;
  double* levers = out.lanes->levers_of(s);
  for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
    const Mat3 Ri = load_mat3(R + 9 * nb.frames[p]);
    const Vec3 g = load3(&nb.weight_gradients[3 * p]);
    const Vec3 ap = load3(a + 3 * (p - nb.offsets[s]));
    store3(&out.offsets[3 * p], ap);
    const Mat3 M = pair_lever(ap, g, nb.weights[p], Ri);
    SampleLanes::set_lever(levers, p - nb.offsets[s], M);
    // Pair buffer: energy gradient share (columns 0-5) ...
    pair_lever_virtual_work(vP, g, M, &out.pair[6 * p]);
    // ... and the pair's rotational geometric block, which with B = M (v P)^T is
    // sym(B) - tr(B) I (pair_rotational_geometric_block: B = w R (vP)^T + a (vP g)^T),
    // 6 values xx yy zz yz xz xy.
    const Mat3 B = M * transpose(vP);
    const double tr = B.m[0][0] + B.m[1][1] + B.m[2][2];
    double* q = &out.pair_blocks[6 * p];
    q[0] = B.m[0][0] - tr;
    q[1] = B.m[1][1] - tr;
    q[2] = B.m[2][2] - tr;
    q[3] = 0.5 * (B.m[1][2] + B.m[2][1]);
    q[4] = 0.5 * (B.m[0][2] + B.m[2][0]);
    q[5] = 0.5 * (B.m[0][1] + B.m[1][0]);
  }
  return v * psi;
}

}  // namespace

Elasticity::Elasticity(const Model& model, int threads)
    : m_model(model), m_threads(threads > 0 ? threads : omp_get_max_threads()), m_lanes(model) {
  const NeighbourTable& nb = model.neighbours;
  m_table = PairTableView{nb.offsets.data(), nb.frames.data(), nb.weights.data(), nb.weight_gradients.data(),
                          nb.rest_offsets.data()};
  const int s_count = model.sample_count();
  m_offsets.resize(3 * model.pair_count());
  m_F.resize(9 * s_count);
  m_P.resize(9 * s_count);
  m_cache.resize(s_count);
  m_frame_blocks.resize(9 * model.frame_count());
  m_pair.resize(6 * model.pair_count());
  m_pair_blocks.resize(6 * model.pair_count());
  m_max_pairs = model.max_neighbours();
  m_chunk.resize((s_count + kChunk - 1) / kChunk);
}

double Elasticity::energy(const State& state) {
  rotation_matrices(state, m_energy_rotations);  // the prepared rotations stay
  const int s_count = m_model.sample_count();
  const int chunks = static_cast<int>(m_chunk.size());
  const double* x = state.positions.data();
  const double* R = m_energy_rotations.data();
#pragma omp parallel for schedule(static) num_threads(m_threads) if (chunks > 1)
  for (int c = 0; c < chunks; ++c) {
    double sum = 0;
    const int end = std::min(s_count, (c + 1) * kChunk);
    for (int s = c * kChunk; s < end; ++s) {
      const Mat3 F = sample_deformation_gradient(m_table, s, x, R);
      const Material& mat = m_model.materials[m_model.samples.materials[s]];
      sum += m_model.samples.volumes[s] * energy_density(mat, F);
    }
    m_chunk[c] = sum;
  }
  double w = 0;
  for (double c : m_chunk) w += c;
  return w;
}

double Elasticity::prepare(const State& state) {
  if (m_prepared.valid && state.positions == m_prepared.positions && state.orientations == m_prepared.orientations)
    return m_prepared.energy;
  rotation_matrices(state, m_rotations);
  const int s_count = m_model.sample_count();
  const int chunks = static_cast<int>(m_chunk.size());
  const double* x = state.positions.data();
  const double* R = m_rotations.data();
  const PreparedArrays arrays{m_F.data(),    m_P.data(),           m_cache.data(), m_offsets.data(),
                              m_pair.data(), m_pair_blocks.data(), &m_lanes};
#pragma omp parallel for schedule(static) num_threads(m_threads) if (chunks > 1)
  for (int c = 0; c < chunks; ++c) {
    double sum = 0;
    std::vector<double> a(3 * static_cast<size_t>(m_max_pairs));
    const int end = std::min(s_count, (c + 1) * kChunk);
    for (int s = c * kChunk; s < end; ++s) sum += prepare_sample(m_model, s, x, R, a.data(), arrays);
    m_chunk[c] = sum;
  }
  // The rotational geometric blocks, summed per frame through the reverse table.
  const int n = m_model.frame_count();
#pragma omp parallel for schedule(static) num_threads(m_threads) if (n > kParallelMin)
  for (int i = 0; i < n; ++i) {
    double K[6] = {0, 0, 0, 0, 0, 0};
    for (int k = m_model.reverse.offsets[i]; k < m_model.reverse.offsets[i + 1]; ++k) {
      const double* q = &m_pair_blocks[6 * m_model.reverse.pairs[k]];
      for (int j = 0; j < 6; ++j) K[j] += q[j];
    }
    double* G = &m_frame_blocks[9 * i];
    G[0] = K[0], G[1] = K[5], G[2] = K[4];
    G[3] = K[5], G[4] = K[1], G[5] = K[3];
    G[6] = K[4], G[7] = K[3], G[8] = K[2];
  }
  double w = 0;
  for (double c : m_chunk) w += c;
  m_prepared.valid = true;
  m_prepared.positions = state.positions;
  m_prepared.orientations = state.orientations;
  m_prepared.energy = w;
  return w;
}

double Elasticity::gradient(const State& state, double* gradient) {
  const double w = prepare(state);  // the pair shares of the gradient are prepare's
  gather(gradient);
  return w;
}

void Elasticity::gather(double* out) const {
  const int n = m_model.frame_count();
  const ReverseTable& rev = m_model.reverse;
#pragma omp parallel for schedule(static) num_threads(m_threads) if (n > kParallelMin)
  for (int i = 0; i < n; ++i) {
    double acc[6] = {0, 0, 0, 0, 0, 0};
    for (int k = rev.offsets[i]; k < rev.offsets[i + 1]; ++k) {
      const double* q = &m_pair[6 * rev.pairs[k]];
      for (int j = 0; j < 6; ++j) acc[j] += q[j];
    }
    for (int j = 0; j < 6; ++j) out[6 * i + j] = acc[j];
  }
}

void Elasticity::apply_tangent(const double* d, double* out, const double* frame_diagonal) {
  // Pass 1 (blocks of samples, sample_lanes.hpp): dF = sum_p B_p d_i (eq. 11), v dP (eq. 22-24
  // in the P form, with the stress part dF S of eq. 25-26), each pair's share B_p^T v dP (eq. 21,
  // 23). Pass 2 (frames): sum the pairs, add the rotational geometric block and frame_diagonal.
  const int blocks = m_lanes.block_count();
  const int n = m_model.frame_count();
  const double* F = m_F.data();
  const MaterialCache* cache = m_cache.data();
  const double* G = m_frame_blocks.data();
#pragma omp parallel num_threads(m_threads) if (m_model.sample_count() > kParallelMin)
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    m_lanes.pair_products(d, m_model, F, cache, blocks * t / nt, blocks * (t + 1) / nt);
#pragma omp barrier
    m_lanes.gather(d, G, frame_diagonal, out, static_cast<int>(static_cast<long>(n) * t / nt),
                   static_cast<int>(static_cast<long>(n) * (t + 1) / nt));
  }
}

void Elasticity::material_matrix(int s, double* D) const {
  const Material& mat = m_model.materials[m_model.samples.materials[s]];
  const Mat3 F = load_mat3(&m_F[9 * s]);
  for (int k = 0; k < 9; ++k) {
    Mat3 E = zero3();
    E.m[k / 3][k % 3] = 1;
    store_mat3(D + 9 * k, pk1_differential(mat, F, m_cache[s], E));
  }
}

void Elasticity::pair_jacobian(int p, double* B) const {
  const NeighbourTable& nb = m_model.neighbours;
  const int i = nb.frames[p];
  const Vec3 a = load3(&m_offsets[3 * p]);
  const Vec3 g = load3(&nb.weight_gradients[3 * p]);
  const Mat3 Ri = load_mat3(&m_rotations[9 * i]);
  for (int k = 0; k < 6; ++k) {
    Vec3 dx{0, 0, 0}, dr{0, 0, 0};
    (k < 3 ? dx : dr) = Vec3{k % 3 == 0 ? 1.0 : 0.0, k % 3 == 1 ? 1.0 : 0.0, k % 3 == 2 ? 1.0 : 0.0};
    const Mat3 dF = pair_deformation_differential(dx, dr, a, g, nb.weights[p], Ri);
    for (int r = 0; r < 9; ++r) B[6 * r + k] = dF.m[r / 3][r % 3];
  }
}

Mat3 Elasticity::lever(int p) const {
  const NeighbourTable& nb = m_model.neighbours;
  return pair_lever(load3(&m_offsets[3 * p]), load3(&nb.weight_gradients[3 * p]), nb.weights[p],
                    load_mat3(&m_rotations[9 * nb.frames[p]]));
}

void Elasticity::tangent_diagonal_blocks(double* blocks) {
  const int n = m_model.frame_count();
  const ReverseTable& rev = m_model.reverse;
#pragma omp parallel for schedule(dynamic, 64) num_threads(m_threads) if (n > kParallelMin)
  for (int i = 0; i < n; ++i) {
    double K[36] = {0};
    double D[81], B[54], DB[54];
    for (int k = rev.offsets[i]; k < rev.offsets[i + 1]; ++k) {
      const int p = rev.pairs[k];
      const int s = rev.pair_samples[p];
      material_matrix(s, D);
      pair_jacobian(p, B);
      const double v = m_model.samples.volumes[s];
      // K_ii += v B^T D^T B; D is symmetric for a hyperelastic law (D = d^2 psi / dF^2), rows of D
      // are vec(dP[E_k]).
      for (int r = 0; r < 9; ++r)
        for (int c = 0; c < 6; ++c) {
          double acc = 0;
          for (int q = 0; q < 9; ++q) acc += D[9 * q + r] * B[6 * q + c];
          DB[6 * r + c] = acc;
        }
      for (int a = 0; a < 6; ++a)
        for (int b = 0; b < 6; ++b) {
          double acc = 0;
          for (int r = 0; r < 9; ++r) acc += B[6 * r + a] * DB[6 * r + b];
          K[6 * a + b] += v * acc;
        }
    }
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) K[6 * (3 + a) + 3 + b] += m_frame_blocks[9 * i + 3 * a + b];
    for (int j = 0; j < 36; ++j) blocks[36 * i + j] = K[j];
  }
}

}  // namespace fascia
