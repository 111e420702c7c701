#include "mechanics/sample_lanes.hpp"

#include "core/target_clones.hpp"
#include "mechanics/frame_sample.hpp"

#include <algorithm>

// The lane loops below are written for the compiler's vectoriser (#pragma omp simd over kLanes
// contiguous doubles), compiled for SSE2 and AVX2 + FMA (core/target_clones.hpp).

namespace fascia {
namespace {

constexpr int L = kLanes;
constexpr int kBlockValues = 17;  // F or F^-T (9), v S (6) or v c (1), v lambda, v mu
// A pair's share of K d is stored as one 64-byte record (6 values, 2 zeros): the frame pass reads
// it with two vector loads from one cache line.
constexpr int kShareValues = 8;
// Samples are put in lanes by neighbour count within windows of this many consecutive samples:
// few empty slot lanes (pelvis 2.6 % of 9,212, liver 2.3 %, coupling 1.5 %; 23 %, 23 % and 13.5 %
// with four consecutive samples of the Poisson-disk order per block), while a block's samples
// stay near one another and read nearby frames.
constexpr int kSortWindow = 64;

// Lane l of a [k][L] matrix / vector stored from p.
inline Mat3 lane_mat3(const double* p, int l) {
  return Mat3{{{p[0 * L + l], p[1 * L + l], p[2 * L + l]},
               {p[3 * L + l], p[4 * L + l], p[5 * L + l]},
               {p[6 * L + l], p[7 * L + l], p[8 * L + l]}}};
}
inline Vec3 lane_vec3(const double* p, int l) { return Vec3{p[0 * L + l], p[1 * L + l], p[2 * L + l]}; }
inline void lane_store_mat3(double* p, int l, const Mat3& a) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p[(3 * r + c) * L + l] = a.m[r][c];
}

// The law of a block's lanes: all StVK, all neo-Hookean (each with the lane code of its own), or
// mixed or another law (pk1_differential lane by lane).
enum BlockLaw : std::uint8_t { kStvk, kNeoHookean, kGeneric };

// v dP for a block of mixed laws or another law (scalar, generic law).
void generic_lanes(const Model& model, const int* lane_samples, const double* F, const MaterialCache* cache, int block,
                   const double* dF, double* vdP) {
  for (int l = 0; l < L; ++l) {
    const int s = lane_samples[block * L + l];
    if (s < 0) {
      lane_store_mat3(vdP, l, zero3());
      continue;
    }
    const Material& mat = model.materials[model.samples.materials[s]];
    const Mat3 dP = pk1_differential(mat, load_mat3(F + 9 * s), cache[s], lane_mat3(dF, l));
    lane_store_mat3(vdP, l, model.samples.volumes[s] * dP);
  }
}

// AVX2 at most: its AVX-512 clone took 10-54 % more time on the shipped scenes (perf, one
// thread, on a 2-core Intel Xeon VM: quasi_static_press, tool_pull, liver).
FASCIA_CLONES_AVX2
void pair_products_kernel(const int* __restrict block_slots, const std::uint8_t* __restrict laws,
                          const int* __restrict lane_samples,
                          const int* __restrict slot_frames, const double* __restrict slot_data,
                          const double* __restrict block_data, const double* __restrict d,
                          double* __restrict slot_out, const Model& model, const double* F,
                          const MaterialCache* cache, int first, int last) {
  for (int b = first; b < last; ++b) {
    const int slot_begin = block_slots[b], slot_end = block_slots[b + 1];
    alignas(64) double dF[9 * L] = {};
    // dF = sum over slots of dx g^T + [dr]x M (eq. 11).
    for (int q = slot_begin; q < slot_end; ++q) {
      const int* frames = slot_frames + L * q;
      const double* slot = slot_data + kSlotValues * L * q;
      alignas(64) double dd[6 * L];
      for (int l = 0; l < L; ++l)
        for (int j = 0; j < 6; ++j) dd[j * L + l] = d[frames[l] + j];
#pragma omp simd
      for (int l = 0; l < L; ++l) {
        const Mat3 t = pair_lever_differential(lane_vec3(dd, l), lane_vec3(dd + 3 * L, l), lane_vec3(slot + 9 * L, l),
                                               lane_mat3(slot, l));
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) dF[(3 * r + c) * L + l] += t.m[r][c];
      }
    }
    // v dP (eq. 22-26).
    alignas(64) double vdP[9 * L];
    if (laws[b] == kGeneric) {
      generic_lanes(model, lane_samples, F, cache, b, dF, vdP);
    } else if (laws[b] == kNeoHookean) {
      const double* mat = block_data + kBlockValues * L * b;
#pragma omp simd
      for (int l = 0; l < L; ++l)  // the law's differential with v in its moduli: v dP
        lane_store_mat3(vdP, l,
                        neo_hookean_pk1_differential<double>(mat[15 * L + l], mat[16 * L + l], lane_mat3(mat, l),
                                                             mat[9 * L + l], lane_mat3(dF, l)));
    } else {
      const double* mat = block_data + kBlockValues * L * b;
#pragma omp simd
      for (int l = 0; l < L; ++l) {
        const Mat3 Fl = lane_mat3(mat, l);
        const Mat3 dFl = lane_mat3(dF, l);
        const double sxx = mat[9 * L + l], syy = mat[10 * L + l], szz = mat[11 * L + l];
        const double syz = mat[12 * L + l], sxz = mat[13 * L + l], sxy = mat[14 * L + l];
        const Mat3 vS{{{sxx, sxy, sxz}, {sxy, syy, syz}, {sxz, syz, szz}}};
        const double vlambda = mat[15 * L + l], vmu = mat[16 * L + l];
        // dE = sym(F^T dF); v dS = v lambda tr(dE) I + 2 v mu dE.
        const Mat3 A = transpose(Fl) * dFl;
        const double tr = A.m[0][0] + A.m[1][1] + A.m[2][2];
        Mat3 dS;
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) dS.m[r][c] = vmu * (A.m[r][c] + A.m[c][r]);
        dS.m[0][0] += vlambda * tr;
        dS.m[1][1] += vlambda * tr;
        dS.m[2][2] += vlambda * tr;
        lane_store_mat3(vdP, l, dFl * vS + Fl * dS);
      }
    }
    // Each pair's share [v dP g, axial(M (v dP)^T)] (eq. 21, 23).
    for (int q = slot_begin; q < slot_end; ++q) {
      const double* slot = slot_data + kSlotValues * L * q;
      alignas(64) double out[6 * L];  // local: the vectoriser handles it as it does dF
#pragma omp simd
      for (int l = 0; l < L; ++l) {
        const Mat3 P = lane_mat3(vdP, l), M = lane_mat3(slot, l);
        const Vec3 u = P * lane_vec3(slot + 9 * L, l);  // pair_lever_virtual_work, lane by lane
        const Vec3 t = axial_times_transpose(M, P);
        out[0 * L + l] = u.x;
        out[1 * L + l] = u.y;
        out[2 * L + l] = u.z;
        out[3 * L + l] = t.x;
        out[4 * L + l] = t.y;
        out[5 * L + l] = t.z;
      }
      double* share = slot_out + kShareValues * L * q;  // [kLanes][kShareValues], lanes transposed
      for (int l = 0; l < L; ++l)
        for (int j = 0; j < 6; ++j) share[kShareValues * l + j] = out[j * L + l];
    }
  }
}

// out_i = sum of frame i's share records + [t_i dx_i, (G_i + Q_i) dr_i] (SampleLanes::gather).
FASCIA_CLONES
void frame_sums_kernel(const int* __restrict frame_offsets, const int* __restrict frame_entries,
                       const double* __restrict shares, const double* __restrict d, const double* __restrict G,
                       const double* __restrict extra, double* __restrict out, int first, int last) {
  for (int i = first; i < last; ++i) {
    double acc[kShareValues] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (int k = frame_offsets[i]; k < frame_offsets[i + 1]; ++k) {
      const double* q = shares + frame_entries[k];
#pragma omp simd
      for (int j = 0; j < kShareValues; ++j) acc[j] += q[j];
    }
    const double* di = d + 6 * i;
    const double* Gi = G + 9 * i;
    double* o = out + 6 * i;
    if (extra) {
      const double* e = extra + 10 * i;
      for (int j = 0; j < 3; ++j) o[j] = acc[j] + e[0] * di[j];
      for (int r = 0; r < 3; ++r)
        o[3 + r] = acc[3 + r] + (Gi[3 * r] + e[1 + 3 * r]) * di[3] + (Gi[3 * r + 1] + e[2 + 3 * r]) * di[4] +
                   (Gi[3 * r + 2] + e[3 + 3 * r]) * di[5];
    } else {
      for (int j = 0; j < 3; ++j) o[j] = acc[j];
      for (int r = 0; r < 3; ++r) o[3 + r] = acc[3 + r] + Gi[3 * r] * di[3] + Gi[3 * r + 1] * di[4] + Gi[3 * r + 2] * di[5];
    }
  }
}

}  // namespace

SampleLanes::SampleLanes(const Model& model) {
  const int s_count = model.sample_count();
  const int blocks = (s_count + L - 1) / L;
  const NeighbourTable& nb = model.neighbours;
  auto pairs_of = [&](int s) { return nb.offsets[s + 1] - nb.offsets[s]; };
  // Lane positions: the samples of each window of kSortWindow consecutive ones by decreasing
  // neighbour count, so that a block's samples have about as many pairs and few slots are empty.
  m_lane_samples.assign(static_cast<size_t>(L) * blocks, -1);
  for (int s = 0; s < s_count; ++s) m_lane_samples[s] = s;
  for (int w = 0; w < s_count; w += kSortWindow)
    std::stable_sort(m_lane_samples.begin() + w, m_lane_samples.begin() + std::min(s_count, w + kSortWindow),
                     [&](int x, int y) { return pairs_of(x) > pairs_of(y); });
  m_sample_lanes.resize(s_count);
  for (int k = 0; k < s_count; ++k) m_sample_lanes[m_lane_samples[k]] = k;
  m_block_slots.assign(blocks + 1, 0);
  m_laws.assign(blocks, kGeneric);
  for (int b = 0; b < blocks; ++b) {
    int slots = 0;
    bool stvk = true, neo_hookean = true;
    for (int l = 0; l < L; ++l) {
      const int s = m_lane_samples[b * L + l];
      if (s < 0) continue;
      slots = std::max(slots, pairs_of(s));
      const MaterialLaw law = model.materials[model.samples.materials[s]].law;
      stvk = stvk && law == MaterialLaw::stvk;
      neo_hookean = neo_hookean && law == MaterialLaw::neo_hookean;
    }
    m_laws[b] = stvk ? kStvk : neo_hookean ? kNeoHookean : kGeneric;
    m_block_slots[b + 1] = m_block_slots[b] + slots;
  }
  const int slot_count = m_block_slots[blocks];
  m_slot_frames.assign(static_cast<size_t>(L) * slot_count, 0);
  m_slot_data.assign(static_cast<size_t>(kSlotValues) * L * slot_count, 0.0);
  m_block_data.assign(static_cast<size_t>(kBlockValues) * L * blocks, 0.0);
  m_slot_out.assign(static_cast<size_t>(kShareValues) * L * slot_count, 0.0);  // padding stays 0
  // Slot lanes: first DOF (6 i) of the pair's frame i, and g; empty slot lanes read the sample's
  // first frame (any valid frame: their lever and gradient are zero) and are never gathered.
  std::vector<int> entry_of_pair(model.pair_count());
  for (int s = 0; s < s_count; ++s) {
    const int b = m_sample_lanes[s] / L, l = m_sample_lanes[s] % L;
    for (int q = m_block_slots[b]; q < m_block_slots[b + 1]; ++q) {
      const int k = q - m_block_slots[b];
      const int p = nb.offsets[s] + k;
      if (p >= nb.offsets[s + 1]) {
        m_slot_frames[L * q + l] = nb.offsets[s] < nb.offsets[s + 1] ? 6 * nb.frames[nb.offsets[s]] : 0;
        continue;
      }
      m_slot_frames[L * q + l] = 6 * nb.frames[p];
      for (int j = 0; j < 3; ++j) m_slot_data[(kSlotValues * q + 9 + j) * L + l] = nb.weight_gradients[3 * p + j];
      entry_of_pair[p] = kShareValues * (L * q + l);
    }
  }
  // Reverse positions: frame i's pairs in the reverse table's (increasing pair) order.
  const ReverseTable& rev = model.reverse;
  m_frame_offsets = rev.offsets;
  m_frame_entries.resize(rev.pairs.size());
  for (size_t k = 0; k < rev.pairs.size(); ++k) m_frame_entries[k] = entry_of_pair[rev.pairs[k]];
}

void SampleLanes::set_sample(int s, const Material& material, double volume, const Mat3& F,
                             const MaterialCache& cache) {
  double* mat = &m_block_data[static_cast<size_t>(kBlockValues) * L * (m_sample_lanes[s] / L)];
  const int l = m_sample_lanes[s] % L;
  if (material.law == MaterialLaw::neo_hookean) {  // F^-T, v c, v lambda, v mu
    lane_store_mat3(mat, l, cache.a);
    mat[9 * L + l] = volume * cache.c;
    mat[15 * L + l] = volume * material.lambda;
    mat[16 * L + l] = volume * material.mu;
    return;
  }
  lane_store_mat3(mat, l, F);
  if (material.law != MaterialLaw::stvk) return;  // generic lanes read Elasticity's arrays
  const Mat3& S = cache.a;
  const double vs[6] = {S.m[0][0], S.m[1][1], S.m[2][2], S.m[1][2], S.m[0][2], S.m[0][1]};
  for (int j = 0; j < 6; ++j) mat[(9 + j) * L + l] = volume * vs[j];
  mat[15 * L + l] = volume * material.lambda;
  mat[16 * L + l] = volume * material.mu;
}

void SampleLanes::pair_products(const double* d, const Model& model, const double* F, const MaterialCache* cache,
                                int first, int last) {
  pair_products_kernel(m_block_slots.data(), m_laws.data(), m_lane_samples.data(), m_slot_frames.data(), m_slot_data.data(),
                       m_block_data.data(), d, m_slot_out.data(), model, F, cache, first, last);
}

void SampleLanes::gather(const double* d, const double* G, const double* extra, double* out, int first,
                         int last) const {
  frame_sums_kernel(m_frame_offsets.data(), m_frame_entries.data(), m_slot_out.data(), d, G, extra, out, first, last);
}

}  // namespace fascia
