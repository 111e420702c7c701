// The CUDA kernels of the elasticity passes: thin wrappers over the per-thread bodies of
// elasticity_phases.hpp, plus the force pass's deterministic energy reduction.
//
// Reductions: each block sums its values with a fixed shuffle tree and writes one partial; the
// last block to finish (found with an integer atomic counter, the only atomic used) sums the
// partials in block order and writes the scalar. The result does not depend on scheduling.
#pragma once

#include "device_elasticity.hpp"
#include "elasticity_phases.hpp"

#include <cuda_runtime.h>

namespace fascia::gpu {

// The force pass's reduced energy, kept in device memory.
struct Scalars {
  double energy;
};

// Where a kernel's reduction goes (reduce_and_finish): per-block partials, then per-chunk
// partials; the counters (one for the grid, then one per chunk; zero between kernels); the
// scalars.
struct Reduction {
  double* partials;   // [reduce_partial_count(grid)]
  unsigned* counter;  // [reduce_counter_count(grid)]
  Scalars* scalars;
};

// Blocks whose partials one block sums at the reduction's first level: at most 2 per thread of a
// 128-thread block, one round trip to the L2.
constexpr int kReduceChunk = 256;
FASCIA_HD int reduce_chunk_count(int grid) { return (grid + kReduceChunk - 1) / kReduceChunk; }
FASCIA_HD int reduce_counter_count(int grid) { return 1 + reduce_chunk_count(grid); }
FASCIA_HD size_t reduce_partial_count(int grid) {
  return static_cast<size_t>(grid) + static_cast<size_t>(reduce_chunk_count(grid));
}

// Sum over the block, valid on thread 0. Every thread of the block must call it; blockDim.x is
// a multiple of 32.
__device__ inline double block_sum(double v) {
  __shared__ double warp_sums[32];
  for (int o = 16; o > 0; o >>= 1) v += __shfl_down_sync(0xffffffffu, v, o);
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  __syncthreads();
  if (lane == 0) warp_sums[warp] = v;
  __syncthreads();
  double total = 0;
  if (threadIdx.x == 0)
    for (int k = 0; k < static_cast<int>(blockDim.x + 31) / 32; ++k) total += warp_sums[k];
  return total;
}

// This thread's sum of partials[b] for b = threadIdx.x, + blockDim.x, ... < n, in that order, with
// the loads of Rounds strides issued together (one L2 round trip per Rounds strides instead of one
// per stride; the same bits: the adds keep their order).
template <int Rounds>
__device__ inline double strided_partial_sum(const double* partials, unsigned n) {
  double s = 0;
  for (unsigned k = threadIdx.x; k < n; k += Rounds * blockDim.x) {
    double round[Rounds];
#pragma unroll
    for (int u = 0; u < Rounds; ++u) {
      const unsigned b = k + u * blockDim.x;
      round[u] = b < n ? __ldcg(partials + b) : 0.0;
    }
#pragma unroll
    for (int u = 0; u < Rounds; ++u)
      if (k + u * blockDim.x < n) s += round[u];
  }
  return s;
}

// Grid reduction, deterministic: each block writes its sum (thread 0's v after block_sum); the
// last block of each chunk of kReduceChunk blocks (counted by the chunk's counter) sums the
// chunk's partials in block order; the last chunk (the grid's counter) sums the chunks' partials
// in chunk order into the scalars' energy. At the end of a 32,676-block grid of 128 threads (the force
// pass at 4.18 M samples) two round trips to the L2 instead of 32 rounds with one level. Each
// counter is reset by the block that completes it.
__device__ inline void reduce_and_finish(double v, const Reduction& red) {
  __shared__ bool is_last;
  const double block = block_sum(v);
  const unsigned grid = gridDim.x, chunk = blockIdx.x / kReduceChunk;
  const unsigned first = chunk * kReduceChunk, count = min(static_cast<unsigned>(kReduceChunk), grid - first);
  const unsigned chunks = static_cast<unsigned>(reduce_chunk_count(static_cast<int>(grid)));
  double* chunk_partials = red.partials + grid;
  if (threadIdx.x == 0) {
    red.partials[blockIdx.x] = block;
    __threadfence();
    is_last = atomicAdd(red.counter + 1 + chunk, 1u) == count - 1;
  }
  __syncthreads();
  if (!is_last) return;
  const double chunk_sum = block_sum(strided_partial_sum<2>(red.partials + first, count));
  if (threadIdx.x == 0) {
    red.counter[1 + chunk] = 0;
    chunk_partials[chunk] = chunk_sum;
    __threadfence();
    is_last = atomicAdd(red.counter, 1u) == chunks - 1;
  }
  __syncthreads();
  if (!is_last) return;
  const double total = block_sum(strided_partial_sum<2>(chunk_partials, chunks));
  if (threadIdx.x != 0) return;
  *red.counter = 0;
  red.scalars->energy = total;
}

struct Origin {
  double x[3];
};

// Frame kinematics and the frames' lever records of the tangent passes.
template <class R>
__global__ void k_kinematics(int n, const double* positions, const double* orientations, Origin origin, R* x_out,
                             R* r_out, const R* frame_rest, R* levers) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  double x[3], r[9];
  frame_kinematics(i, positions, orientations, origin.x, x, r);
  for (int k = 0; k < 3; ++k) x_out[3 * i + k] = static_cast<R>(x[k]);
  for (int k = 0; k < 9; ++k) r_out[9 * i + k] = static_cast<R>(r[k]);
  write_lever_record(r, frame_rest, i, levers);
}

// ---- force pass ----

// The mask of this thread's group of `Lanes` consecutive lanes within its warp.
template <int Lanes>
__device__ inline unsigned group_lanes_mask() {
  return Lanes == 32 ? 0xffffffffu : ((1u << Lanes) - 1u) << (static_cast<int>(threadIdx.x) & 31 & ~(Lanes - 1));
}

// A summed over the group's `Lanes` lanes (`mask`: group_lanes_mask) by an xor butterfly, the same
// order on every run; every lane of the group holds the sum.
template <int Lanes, class T>
__device__ inline void butterfly_sum(Mat3T<T>& A, unsigned mask) {
#pragma unroll
  for (int r = 0; r < 3; ++r)
#pragma unroll
    for (int c = 0; c < 3; ++c)
      for (int o = Lanes / 2; o > 0; o >>= 1) A.m[r][c] += __shfl_xor_sync(mask, A.m[r][c], o);
}

// One block of consecutive samples (ModelView::block_samples), `Lanes` threads per sample
// (fused_sample's lanes: 1, or kSampleLanes for samples with many pairs, whose blocks hold
// kBlockSamples / Lanes samples), their partial F added by an xor butterfly; dynamic shared memory
// holds one 6-vector per pair of the block, summed per slot. Lane 0 of each sample also packs its
// state for the tangent passes (pack_sample_state, component-major) from the F and cache it has
// just stored. Where `changed` is set and *changed is 0 (the state is the last pass's, whose
// outputs stand) every block returns at once.
template <class R, int Lanes>
__global__ void k_fused_samples(ModelView<R> m, FrameView<R> f, R* F_out, R* cache_out, R* P_out, R* slot_partials,
                                Reduction red, R* state_out, const int* changed) {
  static_assert(Lanes >= 1 && Lanes <= 32 && (Lanes & (Lanes - 1)) == 0, "Lanes: a power of two <= 32");
  if (changed && *changed == 0) return;
  extern __shared__ unsigned char shared_raw[];
  R* local = reinterpret_cast<R*>(shared_raw);
  const int b = blockIdx.x;
  const int s0 = m.block_samples[b], s1 = m.block_samples[b + 1];
  const int pair_base = m.offsets[s0];
  const int lane = static_cast<int>(threadIdx.x) & (Lanes - 1);
  const int s = s0 + static_cast<int>(threadIdx.x) / Lanes;
  const unsigned lanes_mask = group_lanes_mask<Lanes>();  // the sample's lanes (all alike in s < s1)
  double e = 0;
  if (s < s1) {
    e = fused_sample(m, f, s, pair_base, local, F_out, cache_out, P_out, lane, Lanes, [&](Mat3& F) {
      if constexpr (Lanes > 1) butterfly_sum<Lanes>(F, lanes_mask);
    });
    if (lane == 0) pack_sample_state(m, F_out, cache_out, s, state_out);
  }
  __syncthreads();
  for (int q = m.block_slots[b] + threadIdx.x; q < m.block_slots[b + 1]; q += blockDim.x)
    fused_slot_sum(m, local, q, slot_partials);
  reduce_and_finish(e, red);
}

// ---- assembled tangent blocks ----

// A pair's columns of the material tangent, v C[B_p e_c] for the 6 unit increments e_c of its
// frame (eq. 11, 22-24): [P][kPairColumns] doubles, column c's dP (3 x 3 row-major) at 9 c. One
// thread per pair, from the sample's state of the last preparation.
constexpr int kPairColumns = 54;

template <class R>
FASCIA_HD EllPair<R> block_pair(const ModelView<R>& m, const FrameView<R>& f, int q, const Vec3T<R>& ps) {
  const EllEntry<R> en{m.frame_of[q], 0, m.weights[q],
                       Vec3T<R>{m.gradients[3LL * q], m.gradients[3LL * q + 1], m.gradients[3LL * q + 2]}};
  return ell_pair_of(en, f.levers, ps);
}

template <class R>
__global__ void k_pair_columns(ModelView<R> m, FrameView<R> f, double* columns) {
  const int q = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (q >= m.pairs) return;
  const int s = m.pair_samples[q];
  const Vec3T<R> ps{sample_value(f.sample_state, m.samples, 0, s), sample_value(f.sample_state, m.samples, 1, s),
                    sample_value(f.sample_state, m.samples, 2, s)};
  const EllPair<R> pair = block_pair(m, f, q, ps);
  Mat3T<R> F;
  MaterialCacheT<R> cache;
  const Material& mat = m.materials[m.sample_materials[s]];
  ell_sample_material(m, f.sample_state, s, mat, F, cache);
  const double v = static_cast<double>(sample_value(f.sample_state, m.samples, 3, s));
  const Vec3T<R> zero{R(0), R(0), R(0)};
  double* out = columns + static_cast<long long>(kPairColumns) * q;
#pragma unroll
  for (int c = 0; c < 6; ++c) {
    const Vec3T<R> e{R(c % 3 == 0), R(c % 3 == 1), R(c % 3 == 2)};
    const Mat3T<R> dP =
        pk1_differential(mat, F, cache, pair_lever_differential(c < 3 ? e : zero, c < 3 ? zero : e, pair.g, pair.M));
#pragma unroll
    for (int r = 0; r < 3; ++r)
#pragma unroll
      for (int k = 0; k < 3; ++k) out[9 * c + 3 * r + k] = v * static_cast<double>(dP.m[r][k]);
  }
}

// The elastic tangent's blocks between frames that share a sample, sum_s v B_a^T C[B_b] (eq. 11,
// 21-26, without the rotational geometric blocks), written into blocks [B][36] (H entry
// (6a + r, 6b + c) of block p at 36 p + 6 r + c; a block without terms, b > a, as zero). A warp
// per block: lane l sums the terms l, l + 32, ... of the block's list (contributions [C][2]: the
// pairs (p_a, p_b) of one sample with frames a and b, over [contribution_offsets[p],
// contribution_offsets[p + 1])), each term B_a^T (v C[B_b e_c]) for the six columns c from p_b's
// columns (k_pair_columns), and an xor butterfly adds the lanes' 36 sums: no atomics, the same
// bits on every run. The lanes' terms are independent loads, where a thread per column walked its
// block's list (about 150 terms in the pelvis at 56 k samples) one dependent load after another.
constexpr int kTangentBlockThreads = 128;  // k_tangent_blocks: threads per block, four warps

template <class R>
__global__ void __launch_bounds__(kTangentBlockThreads)
    k_tangent_blocks(ModelView<R> m, FrameView<R> f, int block_count, const int* contribution_offsets,
                     const int* contributions, const double* columns, double* blocks) {
  const long long t = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  const int p = static_cast<int>(t / 32), lane = static_cast<int>(t % 32);
  if (p >= block_count) return;  // the warp's lanes alike
  double acc[36];
#pragma unroll
  for (int e = 0; e < 36; ++e) acc[e] = 0;
  for (int k = contribution_offsets[p] + lane; k < contribution_offsets[p + 1]; k += 32) {
    const int pa = contributions[2LL * k], pb = contributions[2LL * k + 1], s = m.pair_samples[pa];
    const Vec3T<R> ps{sample_value(f.sample_state, m.samples, 0, s), sample_value(f.sample_state, m.samples, 1, s),
                      sample_value(f.sample_state, m.samples, 2, s)};
    const EllPair<R> qa = block_pair(m, f, pa, ps);
    Mat3 M;
    for (int r = 0; r < 3; ++r)
      for (int e = 0; e < 3; ++e) M.m[r][e] = static_cast<double>(qa.M.m[r][e]);
    const Vec3 g{static_cast<double>(qa.g.x), static_cast<double>(qa.g.y), static_cast<double>(qa.g.z)};
    const double* column = columns + static_cast<long long>(kPairColumns) * pb;
#pragma unroll
    for (int c = 0; c < 6; ++c) {
      double out[6];
      pair_lever_virtual_work(ldm(column + 9 * c), g, M, out);
#pragma unroll
      for (int r = 0; r < 6; ++r) acc[6 * r + c] += out[r];
    }
  }
#pragma unroll
  for (int e = 0; e < 36; ++e)
    for (int o = 16; o > 0; o >>= 1) acc[e] += __shfl_xor_sync(0xffffffffu, acc[e], o);
#pragma unroll
  for (int e = 0; e < 36; ++e)
    if (e % 32 == lane) blocks[36LL * p + e] = acc[e];
}

// blocks[p] += the rotational geometric block Kr of frame i (geo [N][9], row-major) in its rotation
// rows and columns, p = diagonal_blocks[i] (-1: none). One thread per frame.
template <class R>
__global__ void k_add_rotational_geometric(int frames, const int* diagonal_blocks, const R* geo, double* blocks) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= frames || diagonal_blocks[i] < 0) return;
  double* B = blocks + 36LL * diagonal_blocks[i];
#pragma unroll
  for (int r = 0; r < 3; ++r)
#pragma unroll
    for (int c = 0; c < 3; ++c) B[6 * (3 + r) + 3 + c] += static_cast<double>(geo[9LL * i + 3 * r + c]);
}

// ---- tangent product ----

// The slot sums of block b's outputs [6][stride] in slot-major order (the coalesced pass):
// `slot_lanes` lanes per slot (a power of two <= 32; 1: a thread per slot), lane l of a slot's
// group adds its positions l, l + slot_lanes, ... per component, an xor butterfly within the
// group combines the lanes (slot_tree_sum's order, so the host emulation has the same bits), and
// the group's lanes 0..5 write the six components (lane 0 all six when slot_lanes < 6). Every
// thread of the block must call it (blockDim.x a multiple of 32).
// One slot's sum by its group of `slot_lanes` lanes (warp_slot_sums' arithmetic): positions [a, e)
// of outs [6][stride], the six components into dst where `valid`. Every lane of the warp must call it.
template <class R>
__device__ inline void slot_sum_store(const R* outs, int stride, int a, int e, bool valid, int lane, int slot_lanes,
                                      R* dst) {
  R acc[6] = {0, 0, 0, 0, 0, 0};
  if (valid)
    for (int k = a + lane; k < e; k += slot_lanes)
#pragma unroll
      for (int c = 0; c < 6; ++c) acc[c] += outs[c * stride + k];
  for (int o = slot_lanes / 2; o > 0; o >>= 1)
#pragma unroll
    for (int c = 0; c < 6; ++c) acc[c] += __shfl_xor_sync(0xffffffffu, acc[c], o);
  if (!valid) return;
  if (slot_lanes < 6) {
    if (lane == 0)
#pragma unroll
      for (int c = 0; c < 6; ++c) dst[c] = acc[c];
  } else {
    R mine = 0;
#pragma unroll
    for (int c = 0; c < 6; ++c)
      if (lane == c) mine = acc[c];
    if (lane < 6) dst[lane] = mine;
  }
}

template <class R>
__device__ void warp_slot_sums(const ModelView<R>& m, const R* outs, int stride, int b, int slot_lanes,
                               R* slot_partials) {
  const int lane = static_cast<int>(threadIdx.x) & (slot_lanes - 1);
  const int group = static_cast<int>(threadIdx.x) / slot_lanes, groups = static_cast<int>(blockDim.x) / slot_lanes;
  const int q0 = m.block_slots[b], q1 = m.block_slots[b + 1];
  const int base = m.slot_pair_offsets[q0];
  for (int first = q0; first < q1; first += groups) {  // the same trip count in every thread
    const int q = first + group;
    const bool valid = q < q1;
    slot_sum_store(outs, stride, valid ? m.slot_pair_offsets[q] - base : 0, valid ? m.slot_pair_offsets[q + 1] - base : 0,
                   valid, lane, slot_lanes, slot_partials + 6 * static_cast<size_t>(valid ? q : 0));
  }
}

// Coalesced tangent pass of block b (elasticity_phases.hpp, "coalesced tangent pass"), `Lanes`
// threads per sample (1, or a power of two <= 32 for samples with many neighbour frames: the
// pairs of a sample are a chain of dependent loads, and its lanes share them): block-local sample
// t has its pairs j at ELL entries e0 + j ns + t, lane l takes j = l, l + Lanes, ...; the first
// Keep of a lane's pairs have their ELL entries loaded at once (independent loads in flight
// together) and kept in registers for the output half; further ones are read again. The lanes'
// dF are summed by an xor butterfly, and each lane forms dP and its pairs' outputs. The frames'
// lever records are gathered in each half (the second read hits the cache). Outputs [6][P_b] in
// slot-major order in `local`, then `slot_lanes` lanes per slot sum it (warp_slot_sums). All
// arithmetic in R. Every thread of the block must call it.
template <class R, int Keep, int Lanes = 1>
__device__ void ell_tangent_block(const ModelView<R>& m, const FrameView<R>& f, const R* d, int b, int slot_lanes,
                                  R* local, R* slot_partials) {
  static_assert(Lanes >= 1 && Lanes <= 32 && (Lanes & (Lanes - 1)) == 0, "Lanes: a power of two <= 32");
  const int s0 = m.block_samples[b], ns = m.block_samples[b + 1] - s0;
  const int e0 = m.ell_offsets[b];
  const int stride = m.offsets[s0 + ns] - m.offsets[s0];  // the block's pairs
  const int groups = static_cast<int>(blockDim.x) / Lanes;
  const int lane = static_cast<int>(threadIdx.x) & (Lanes - 1);
  // The sample's lanes within the warp, for the butterfly.
  const unsigned lanes_mask = group_lanes_mask<Lanes>();
  for (int base = 0; base < ns; base += groups) {  // the same trip count in every thread
    const int t = base + static_cast<int>(threadIdx.x) / Lanes, s = s0 + t;
    if (t >= ns) continue;  // all lanes of a sample alike
    const int count = m.offsets[s + 1] - m.offsets[s];
    const Vec3T<R> ps{sample_value(f.sample_state, m.samples, 0, s), sample_value(f.sample_state, m.samples, 1, s),
                      sample_value(f.sample_state, m.samples, 2, s)};
    Mat3T<R> dF = zero3<R>();
    EllEntry<R> kept[Keep] = {};
#pragma unroll
    for (int k = 0; k < Keep; ++k)
      if (lane + k * Lanes < count) kept[k] = ell_entry(m, e0 + (lane + k * Lanes) * ns + t);
#pragma unroll
    for (int k = 0; k < Keep; ++k)
      if (lane + k * Lanes < count) ell_pair_dF(ell_pair_of(kept[k], f.levers, ps), d, dF);
    for (int j = lane + Keep * Lanes; j < count; j += Lanes)
      ell_pair_dF(ell_pair_of(ell_entry(m, e0 + j * ns + t), f.levers, ps), d, dF);
    if constexpr (Lanes > 1) butterfly_sum<Lanes>(dF, lanes_mask);
    if (count > 0) {
      const Mat3T<R> dP = ell_sample_dP(m, f.sample_state, s, dF);
      const R v = sample_value(f.sample_state, m.samples, 3, s);
#pragma unroll
      for (int k = 0; k < Keep; ++k)
        if (lane + k * Lanes < count) ell_pair_output(ell_pair_of(kept[k], f.levers, ps), dP, v, kept[k].pos, stride, local);
      for (int j = lane + Keep * Lanes; j < count; j += Lanes) {
        const EllEntry<R> en = ell_entry(m, e0 + j * ns + t);
        ell_pair_output(ell_pair_of(en, f.levers, ps), dP, v, en.pos, stride, local);
      }
    }
  }
  __syncthreads();
  warp_slot_sums(m, local, stride, b, slot_lanes, slot_partials);
}

// Threads per block of the launched coalesced tangent kernel, and its blocks per multiprocessor,
// whose register budget is 65,536 / (128 blocks): more resident warps keep more loads in flight
// in this latency-bound pass, even at the price of local memory. ptxas -v (sm_90) gives every
// variant its budget and spills a few hundred bytes a thread (double, 2 held entries: 128
// registers and 504 bytes of spill stores); without spills that variant takes 224 registers,
// 2 blocks per multiprocessor, and ran slower (the pelvis at 56 k samples on an H200, ncu: 135 µs
// a product against 114; 3 blocks and 168 registers: the same step times).
constexpr int kDenseThreads = 128;
template <class R>
constexpr int dense_blocks_per_sm(int keep) {
  if (sizeof(R) == sizeof(float)) return keep == 2 ? 8 : 6;
  return 4;
}

// Coalesced tangent pass, one block of kDenseThreads threads per sample block.
template <class R, int Keep, int Lanes>
__global__ void __launch_bounds__(kDenseThreads, dense_blocks_per_sm<R>(Keep))
    k_ell_tangent(ModelView<R> m, FrameView<R> f, const R* d, R* slot_partials, int slot_lanes) {
  extern __shared__ unsigned char shared_raw[];
  R* local = reinterpret_cast<R*>(shared_raw);
  ell_tangent_block<R, Keep, Lanes>(m, f, d, static_cast<int>(blockIdx.x), slot_lanes, local, slot_partials);
}

// The frame pass of the launched tangent product, `Lanes` threads per frame (1, or a power of two
// <= 32 for frames with many slots: their slots are a chain of dependent loads, which the lanes
// share): frames (blockIdx.x blockDim.x + threadIdx.x) / Lanes, + gridDim.x blockDim.x / Lanes, ...
// (a grid of the blocks that fit on the device at once). Lane l of a frame reads the 6 partials of
// its slots l, l + Lanes, ... in vector loads, two slots per round, with no block barrier, and
// sums them in slot order; an xor butterfly adds the lanes' sums, and lane 0 forms
// out = K d (frame_row: the rotational geometric block geo, null for the force pass's gather,
// where d is null too) plus, where frame_diagonal [N][10] is set, D d with
// D = diag(t_i I3, Q_i) (t_i, then Q_i row-major: the step's frame terms, as
// Elasticity::apply_tangent takes them), in double.
constexpr int kFrameThreads = 128;  // threads per block of k_frame_sums

template <class R, int Lanes = 1>
__global__ void k_frame_sums(ModelView<R> m, const R* slot_partials, const R* geo, const R* d,
                             const double* frame_diagonal, double* out) {
  static_assert(Lanes >= 1 && Lanes <= 32 && (Lanes & (Lanes - 1)) == 0, "Lanes: a power of two <= 32");
  const int lane = static_cast<int>(threadIdx.x) & (Lanes - 1);
  const unsigned lanes_mask = group_lanes_mask<Lanes>();
  const int stride = static_cast<int>(gridDim.x * blockDim.x) / Lanes;
  for (int i = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x) / Lanes; i < m.frames; i += stride) {
    // The frame's slot partials, two of the lane's slots' 6 values per round, added in slot order.
    double acc[6] = {0, 0, 0, 0, 0, 0};
    const int q1 = m.frame_slot_offsets[i + 1];
    for (int q = m.frame_slot_offsets[i] + lane; q < q1; q += 2 * Lanes) {
      R part[2][6];
#pragma unroll
      for (int u = 0; u < 2; ++u)
        if (q + u * Lanes < q1) load_six(slot_partials, m.frame_slots ? m.frame_slots[q + u * Lanes] : q + u * Lanes, part[u]);
#pragma unroll
      for (int u = 0; u < 2; ++u)
        if (q + u * Lanes < q1)
#pragma unroll
          for (int k = 0; k < 6; ++k) acc[k] += static_cast<double>(part[u][k]);
    }
    if constexpr (Lanes > 1) {
#pragma unroll
      for (int k = 0; k < 6; ++k)
        for (int o = Lanes / 2; o > 0; o >>= 1) acc[k] += __shfl_xor_sync(lanes_mask, acc[k], o);
    }
    if (lane != 0) continue;
    double dir[6] = {0, 0, 0, 0, 0, 0};
    if (d) load_six(d, i, dir);
    double o[6];
#pragma unroll
    for (int k = 0; k < 6; ++k) o[k] = frame_row(geo, dir, i, k, acc[k]);
    if (frame_diagonal) {
      const double* e = frame_diagonal + 10 * static_cast<size_t>(i);
      const Vec3 qr = load_mat3(e + 1) * Vec3{dir[3], dir[4], dir[5]};
      o[0] += e[0] * dir[0], o[1] += e[0] * dir[1], o[2] += e[0] * dir[2];
      o[3] += qr.x, o[4] += qr.y, o[5] += qr.z;
    }
#pragma unroll
    for (int k = 0; k < 6; ++k) out[6 * i + k] = o[k];
  }
}

// ---- frames: preparation ----

// Frame preparation. k_frame_columns: kColumnParts threads per frame, each summing every column
// of K_ii and Kr (WithK) or Kr alone over an interleaved subset of the frame's pairs
// (frame_prepare_pairs: one gather and one first Piola stress per pair for all columns) into its
// own column of shared memory; the parts are then summed in part order. With K_ii the sums are
// stored as sums [N][kPrepareSums] (K_ii row-major, then Kr row-major) and k_frame_finish, one
// thread per frame, stores Kr and K_ii (frame_prepare_blocks); without, Kr goes to geo [N][9]
// directly, from a fifth of the shared memory. A warp per frame: meshless frames meet hundreds of
// samples (about 670 pairs per frame in the pelvis at 56 k samples), whose pairs one thread each
// would walk in turn with the grid's few thousand threads mostly idle.
constexpr int kColumnParts = 32;  // k_frame_columns: threads per frame
constexpr int kColumnFrames = 2;  // k_frame_columns: frames per block, 64 threads (blocks spread evenly)

template <class R, bool WithK>
__global__ void __launch_bounds__(kColumnParts * kColumnFrames)
    k_frame_columns(ModelView<R> m, FrameView<R> f, const R* F, const R* P, double* sums, R* geo) {
  constexpr int kSums = WithK ? kPrepareSums : 9;
  constexpr int kFirst = WithK ? 0 : 36;  // the first of frame_prepare_pairs' indices kept
  __shared__ double part_sums[kSums][kColumnParts * kColumnFrames];  // one column per thread
  const int t = static_cast<int>(threadIdx.x), part = t % kColumnParts;
  const int first = static_cast<int>(blockIdx.x) * kColumnFrames, i = first + t / kColumnParts;
  for (int k = 0; k < kSums; ++k) part_sums[k][t] = 0;
  if (i < m.frames)
    frame_prepare_pairs(m, f, F, P, i, part, kColumnParts, WithK,
                        [&](int k, double value) { part_sums[k - kFirst][t] += value; });
  __syncthreads();
  // Entry e of frame first + e / kSums, summed over the frame's parts in part order.
  for (int e = t; e < kColumnFrames * kSums; e += static_cast<int>(blockDim.x)) {
    const int fl = e / kSums, k = e - kSums * fl;
    if (first + fl >= m.frames) break;
    double sum = 0;
    for (int pp = 0; pp < kColumnParts; ++pp) sum += part_sums[k][kColumnParts * fl + pp];
    if constexpr (WithK)
      sums[kSums * static_cast<size_t>(first) + e] = sum;
    else
      geo[kSums * static_cast<size_t>(first) + e] = static_cast<R>(sum);
  }
}

template <class R>
__global__ void k_frame_finish(int frames, const double* sums, R* geo, double* diag) {
  const int i = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (i >= frames) return;
  double K[36];
  Mat3 Kr;
  unpack_prepare_sums(sums + kPrepareSums * static_cast<size_t>(i), K, Kr);
  frame_prepare_blocks(i, K, Kr, geo, diag);
}

}  // namespace fascia::gpu
