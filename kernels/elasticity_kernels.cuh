// The CUDA kernels of the elasticity passes and of the device PCG. Thin wrappers over the
// per-thread bodies of elasticity_phases.hpp, plus deterministic reductions.
//
// Reductions: each block sums its values with a fixed shuffle tree and writes one partial; the
// last block to finish (found with an integer atomic counter, the only atomic used) sums the
// partials in block order and writes the scalar. The result does not depend on scheduling.
#pragma once

#include "device_elasticity.hpp"
#include "elasticity_phases.hpp"

#include <cooperative_groups.h>
#include <cuda_runtime.h>

namespace fascia::gpu {

// Scalars of the device PCG and of the energy reduction, kept in device memory.
struct Scalars {
  double energy;
  double rz, rz0, alpha, beta;
  int done;        // 1 converged, 2 breakdown (p.Ap <= 0 or not finite)
  int iterations;
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

enum class Finish { energy, alpha, beta, init };

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

// The end of a PCG iteration from its r.z (rz_new): beta = rz_new / rz, rz, the iteration count,
// and done = 1 at the tolerance (r.z <= tolerance^2 r0.z0) or where r.z is not positive.
__device__ inline void end_iteration(double rz_new, double rz0, double tolerance, double& rz, double& beta, int& it,
                                     int& done) {
  beta = rz > 0 ? rz_new / rz : 0;
  rz = rz_new;
  ++it;
  if (tolerance > 0 && rz_new <= tolerance * tolerance * rz0) done = 1;
  if (!(rz_new > 0)) done = 1;
}

// A persistent PCG's scalars at its end, for the host and a following launch.
__device__ inline void store_progress(Scalars* scalars, double rz, double beta, int it, int done) {
  scalars->rz = rz;
  scalars->beta = beta;
  scalars->iterations = it;
  scalars->done = done;
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

// Applies `finish` to the scalars from the grid's total.
__device__ inline void finish_scalars(double total, Finish finish, double tolerance, Scalars& sc) {
  switch (finish) {
    case Finish::energy:
      sc.energy = total;
      break;
    case Finish::init:
      sc.rz = sc.rz0 = total;
      sc.alpha = sc.beta = 0;
      sc.iterations = 0;
      sc.done = total > 0 ? 0 : 1;
      break;
    case Finish::alpha:
      if (total > 0 && total < HUGE_VAL) {
        sc.alpha = sc.rz / total;
      } else {
        sc.alpha = 0;
        sc.done = 2;
      }
      break;
    case Finish::beta:
      end_iteration(total, sc.rz0, tolerance, sc.rz, sc.beta, sc.iterations, sc.done);
      break;
  }
}

// Grid reduction, deterministic: each block writes its sum (thread 0's v after block_sum); the
// last block of each chunk of kReduceChunk blocks (counted by the chunk's counter) sums the
// chunk's partials in block order; the last chunk (the grid's counter) sums the chunks' partials
// in chunk order and applies `finish`. At the end of a 32,676-block grid of 128 threads (the force
// pass at 4.18 M samples) two round trips to the L2 instead of 32 rounds with one level. Each
// counter is reset by the block that completes it.
__device__ inline void reduce_and_finish(double v, const Reduction& red, Finish finish, double tolerance) {
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
  finish_scalars(total, finish, tolerance, *red.scalars);
}

__device__ inline bool finished(const Scalars* sc) { return sc != nullptr && *(volatile const int*)&sc->done != 0; }

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

struct FrameTermsFlags {
  double inv_h2;          // (1 + alpha h)/h^2, 0 for K alone
  bool project;           // zero the rows of fixed DOFs
  double k_scale = 1.0;   // 1 + beta/h
};

// ---- force pass ----

// One block of consecutive samples (ModelView::block_samples), one thread per sample (fused_sample);
// dynamic shared memory holds one 6-vector per pair of the block, summed per slot. Each thread
// also packs its sample's state for the tangent passes (pack_sample_state, component-major) from
// the F and cache it has just stored.
template <class R>
__global__ void k_fused_samples(ModelView<R> m, FrameView<R> f, R* F_out, R* cache_out, R* slot_partials,
                                Reduction red, R* state_out) {
  extern __shared__ unsigned char shared_raw[];
  R* local = reinterpret_cast<R*>(shared_raw);
  const int b = blockIdx.x;
  const int s0 = m.block_samples[b], s1 = m.block_samples[b + 1];
  const int pair_base = m.offsets[s0];
  const int s = s0 + static_cast<int>(threadIdx.x);
  double e = 0;
  if (s < s1) {
    e = fused_sample(m, f, s, pair_base, local, F_out, cache_out);
    pack_sample_state(m, F_out, cache_out, s, state_out);
  }
  __syncthreads();
  for (int q = m.block_slots[b] + threadIdx.x; q < m.block_slots[b + 1]; q += blockDim.x)
    fused_slot_sum(m, local, q, slot_partials);
  reduce_and_finish(e, red, Finish::energy, 0);
}

// ---- assembled tangent blocks ----

// The elastic tangent's blocks between frames that share a sample, sum_s v B_a^T C[B_b] (eq. 11,
// 21-26, without the rotational geometric blocks), written into blocks [B][36] (H entry
// (6a + r, 6b + c) of block p at 36 p + 6 r + c). One thread per block sums the block's terms in
// the fixed order of its list (contributions [C][2]: the pairs (p_a, p_b) of one sample with
// frames a and b, over [contribution_offsets[p], contribution_offsets[p + 1])), forming
// C[B_b e_c] for the 6 components c from the sample's state for each: no atomics, the same bits on
// every run.
template <class R>
__global__ void k_tangent_blocks(ModelView<R> m, FrameView<R> f, int block_count, const int* contribution_offsets,
                                 const int* contributions, double* blocks) {
  const int p = static_cast<int>(blockIdx.x * blockDim.x + threadIdx.x);
  if (p >= block_count) return;
  double acc[36] = {};
  for (int k = contribution_offsets[p]; k < contribution_offsets[p + 1]; ++k) {
    const int pa = contributions[2LL * k], pb = contributions[2LL * k + 1], s = m.pair_samples[pa];
    const Vec3T<R> ps{sample_value(f.sample_state, m.samples, 0, s), sample_value(f.sample_state, m.samples, 1, s),
                      sample_value(f.sample_state, m.samples, 2, s)};
    auto pair = [&](int q) {
      const EllEntry<R> en{m.frame_of[q], 0, m.weights[q],
                           Vec3T<R>{m.gradients[3LL * q], m.gradients[3LL * q + 1], m.gradients[3LL * q + 2]}};
      return ell_pair_of(en, f.levers, ps);
    };
    const EllPair<R> qa = pair(pa), qb = pair(pb);
    Mat3T<R> F;
    MaterialCacheT<R> cache;
    const Material& mat = m.materials[m.sample_materials[s]];
    ell_sample_material(m, f.sample_state, s, mat, F, cache);
    const double v = static_cast<double>(sample_value(f.sample_state, m.samples, 3, s));
    const Vec3T<R> zero{R(0), R(0), R(0)};
#pragma unroll
    for (int c = 0; c < 6; ++c) {
      const Vec3T<R> e{R(c % 3 == 0), R(c % 3 == 1), R(c % 3 == 2)};
      const Mat3T<R> dP =
          pk1_differential(mat, F, cache, pair_lever_differential(c < 3 ? e : zero, c < 3 ? zero : e, qb.g, qb.M));
      R out[6];
      pair_lever_virtual_work(dP, qa.g, qa.M, out);
#pragma unroll
      for (int r = 0; r < 6; ++r) acc[6 * r + c] += v * static_cast<double>(out[r]);
    }
  }
  for (int e = 0; e < 36; ++e) blocks[36LL * p + e] = acc[e];
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
// arithmetic in R. Every thread of the block must call it. Returns this thread's v dF : dP (lane
// 0 of each sample), the sample terms of p . K p for the persistent PCG.
template <class R, int Keep, int Lanes = 1>
__device__ double ell_tangent_block(const ModelView<R>& m, const FrameView<R>& f, const R* d, const R* p_old,
                                    double beta, int b, int slot_lanes, R* local, R* slot_partials) {
  static_assert(Lanes >= 1 && Lanes <= 32 && (Lanes & (Lanes - 1)) == 0, "Lanes: a power of two <= 32");
  const int s0 = m.block_samples[b], ns = m.block_samples[b + 1] - s0;
  const int e0 = m.ell_offsets[b];
  const int stride = m.offsets[s0 + ns] - m.offsets[s0];  // the block's pairs
  const int groups = static_cast<int>(blockDim.x) / Lanes;
  const int lane = static_cast<int>(threadIdx.x) & (Lanes - 1);
  // The sample's lanes within the warp, for the butterfly.
  const unsigned lanes_mask =
      Lanes == 32 ? 0xffffffffu : ((1u << Lanes) - 1u) << (static_cast<int>(threadIdx.x) & 31 & ~(Lanes - 1));
  double work = 0;
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
      if (lane + k * Lanes < count) ell_pair_dF(ell_pair_of(kept[k], f.levers, ps), d, p_old, beta, dF);
    for (int j = lane + Keep * Lanes; j < count; j += Lanes)
      ell_pair_dF(ell_pair_of(ell_entry(m, e0 + j * ns + t), f.levers, ps), d, p_old, beta, dF);
    if constexpr (Lanes > 1) {
#pragma unroll
      for (int r = 0; r < 3; ++r)
#pragma unroll
        for (int c = 0; c < 3; ++c)
          for (int o = Lanes / 2; o > 0; o >>= 1) dF.m[r][c] += __shfl_xor_sync(lanes_mask, dF.m[r][c], o);
    }
    if (count > 0) {
      const Mat3T<R> dP = ell_sample_dP(m, f.sample_state, s, dF);
      const R v = sample_value(f.sample_state, m.samples, 3, s);
      if (lane == 0) work += static_cast<double>(v) * static_cast<double>(ddot(dF, dP));
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
  return work;
}

// Most threads per block of the kernels with one thread per frame row (k_update_rows,
// k_pcg_two_barrier): the size of their per-row shared arrays.
constexpr int kRowThreadsMax = 512;

// Threads per block of the launched coalesced tangent kernel, and its blocks per multiprocessor:
// the most whose register budget (65,536 / (128 blocks)) the pass fits without local memory, as
// ptxas -v reports for sm_90 (registers for 2, 4 and 8 held entries: float 64, 79, 128, double
// 128, 156, 200). More resident warps keep more loads in flight in this latency-bound pass.
constexpr int kDenseThreads = 128;
template <class R>
constexpr int dense_blocks_per_sm(int keep) {
  if (sizeof(R) == sizeof(float)) return keep == 2 ? 8 : keep == 4 ? 6 : 4;
  return keep == 2 ? 4 : keep == 4 ? 3 : 2;
}

// Coalesced tangent pass, one block of kDenseThreads threads per sample block. In the PCG (p_old
// set) the direction is p = z + beta p_old with z = d and beta from the scalars; k_frame_sums
// stores it.
template <class R, int Keep, int Lanes>
__global__ void __launch_bounds__(kDenseThreads, dense_blocks_per_sm<R>(Keep))
    k_ell_tangent(ModelView<R> m, FrameView<R> f, const R* d, const R* p_old, R* slot_partials, const Scalars* sc,
                  int slot_lanes) {
  extern __shared__ unsigned char shared_raw[];
  R* local = reinterpret_cast<R*>(shared_raw);
  if (finished(sc)) return;
  const double beta = p_old ? sc->beta : 0.0;
  ell_tangent_block<R, Keep, Lanes>(m, f, d, p_old, beta, static_cast<int>(blockIdx.x), slot_lanes, local,
                                    slot_partials);
}

// The end of a chunk's PCG row update (update_rows_chunk, frame_update_chunk): row j = 6 i + k
// (thread t of the chunk) stores its updated x_j and r_j, then z_j = (M^-1 r)_j from the chunk's
// residuals `res` (shared memory, one per thread). Returns r_j z_j. Every thread of the block must
// call it.
template <class R>
__device__ double store_and_precondition_row(bool active, const UpdatedRow<R>& u, const R* minv, int i, int k, int t,
                                             R* x, R* r, R* z, double* res) {
  const int j = 6 * i + k;
  if (active) {
    x[j] = u.x;
    r[j] = u.r;
    res[t] = static_cast<double>(u.r);
  }
  __syncthreads();
  double dot = 0;
  if (active) {
    const R zk = static_cast<R>(preconditioned_row(
        [&](int c) { return static_cast<double>(minv[kMinvValues * static_cast<size_t>(i) + minv_index(k, c)]); },
        res + (t - k)));
    z[j] = zk;
    dot = res[t] * static_cast<double>(zk);
  }
  __syncthreads();
  return dot;
}

// PCG update with one thread per frame row, chunk c: frames [c fpc, (c + 1) fpc), fpc =
// blockDim.x / 6: x += alpha p, r -= alpha Ap, z = M^-1 r (block_jacobi's order); returns this
// thread's r_k z_k.
template <class R>
__device__ double update_rows_chunk(int n, const R* minv, const R* p, const R* Ap, R* x, R* r, R* z, double alpha,
                                    int chunk) {
  __shared__ double res[kRowThreadsMax];
  const int fpc = static_cast<int>(blockDim.x) / 6;
  const int t = static_cast<int>(threadIdx.x), i = chunk * fpc + t / 6, k = t - 6 * (t / 6);
  const bool active = t < 6 * fpc && i < n;
  const int j = 6 * i + k;
  UpdatedRow<R> u{};
  if (active) u = update_row(x[j], r[j], alpha, static_cast<double>(p[j]), static_cast<double>(Ap[j]));
  return store_and_precondition_row(active, u, minv, i, k, t, x, r, z, res);
}

// Chunks of fpc = blockDim.x / 6 frames covering n frames.
__device__ inline int frame_chunks(int n) {
  const int fpc = static_cast<int>(blockDim.x) / 6;
  return (n + fpc - 1) / fpc;
}

// The launched PCG update (update_rows_chunk): each block takes chunks blockIdx.x, + gridDim.x,
// ... (a grid of the blocks that fit on the device at once: each block's share of the grid
// reduction, a fence and an atomic, is paid once per block instead of once per chunk); r . z is
// reduced into beta and the stopping test.
template <class R>
__global__ void k_update_rows(int n, const R* minv, const R* p, const R* Ap, R* x, R* r, R* z, Reduction red,
                              double tolerance) {
  if (finished(red.scalars)) return;
  const double alpha = red.scalars->alpha;
  double dot = 0;
  for (int c = static_cast<int>(blockIdx.x); c < frame_chunks(n); c += static_cast<int>(gridDim.x))
    dot += update_rows_chunk(n, minv, p, Ap, x, r, z, alpha, c);
  reduce_and_finish(dot, red, Finish::beta, tolerance);
}

// The frame pass of the launched tangent product, `Lanes` threads per frame (1, or a power of two
// <= 32 for frames with many slots: their slots are a chain of dependent loads, which the lanes
// share): frames (blockIdx.x blockDim.x + threadIdx.x) / Lanes, + gridDim.x blockDim.x / Lanes, ...
// (a grid of the blocks that fit on the device at once). Lane l of a frame reads the 6 partials of
// its slots l, l + Lanes, ... in vector loads, two slots per round, with no block barrier, and
// sums them in slot order; an xor butterfly adds the lanes' sums, and lane 0 forms
// out = H d (frame_row_of). With z set (PCG) the direction p = z + beta p is formed and stored,
// and p . A p (a frame's six rows added first) reduced into alpha. With d null (the force pass's
// gather: no frame terms) d is taken as 0. The update keeps one thread per row (k_update_rows):
// its M^-1 block read per row is the cheaper.
constexpr int kFrameThreads = 128;  // threads per block of k_frame_sums

template <class R, int Lanes = 1>
__global__ void k_frame_sums(ModelView<R> m, const R* slot_partials, const R* geo, const R* inertia_world,
                             FrameTermsFlags flags, R* d, R* out, Reduction red, bool pcg, const R* z) {
  static_assert(Lanes >= 1 && Lanes <= 32 && (Lanes & (Lanes - 1)) == 0, "Lanes: a power of two <= 32");
  if (pcg && finished(red.scalars)) return;
  const double beta = z ? red.scalars->beta : 0.0;
  double dot = 0;
  const int lane = static_cast<int>(threadIdx.x) & (Lanes - 1);
  const unsigned lanes_mask =
      Lanes == 32 ? 0xffffffffu : ((1u << Lanes) - 1u) << (static_cast<int>(threadIdx.x) & 31 & ~(Lanes - 1));
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
    if (z) {
      R zi[6], pi[6];
      load_six(z, i, zi);
      load_six(d, i, pi);
#pragma unroll
      for (int k = 0; k < 6; ++k) dir[k] = static_cast<double>(direction_value(zi[k], pi[k], beta));
    } else if (d) {
      load_six(d, i, dir);
    }
    R outs[6];
#pragma unroll
    for (int k = 0; k < 6; ++k) {
      outs[k] = static_cast<R>(
          frame_row_of(m, geo, inertia_world, flags.inv_h2, flags.project, dir, i, k, acc[k], flags.k_scale));
      dot += dir[k] * static_cast<double>(outs[k]);
    }
#pragma unroll
    for (int k = 0; k < 6; ++k) {
      if (z) d[6 * i + k] = static_cast<R>(dir[k]);
      out[6 * i + k] = outs[k];
    }
  }
  if (pcg) reduce_and_finish(dot, red, Finish::alpha, 0);
}

// ---- frames: preparation and PCG ----

// Frame preparation in two kernels. k_frame_columns: kColumnParts threads per frame, each summing
// every column of K_ii and Kr over an interleaved subset of the frame's pairs (frame_prepare_pairs:
// one gather and one first Piola stress per pair for all columns) into its own column of shared
// memory; the parts are then summed in part order and stored as sums [N][kPrepareSums] (K_ii
// row-major, then Kr row-major). k_frame_finish: 6 threads per frame; thread c forms the frame's
// blocks and Cholesky factor itself (the same bits in each) and solves for column c of the
// preconditioner (frame_prepare_finish's arithmetic, column by column); thread 0 stores the blocks.
// Two kernels, so that the pair sums run with many threads per frame and the factorisation with
// few registers per thread. A warp per frame: meshless frames meet hundreds of samples (about 670
// pairs per frame in the pelvis at 56 k samples), whose pairs one thread each would walk in turn
// with the grid's few thousand threads mostly idle.
constexpr int kColumnParts = 32;  // k_frame_columns: threads per frame
constexpr int kColumnFrames = 2;  // k_frame_columns: frames per block, 64 threads (blocks spread evenly)
constexpr int kFinishFrames = 21;  // k_frame_finish: frames per block, 126 threads

template <class R>
__global__ void __launch_bounds__(kColumnParts * kColumnFrames)
    k_frame_columns(ModelView<R> m, FrameView<R> f, const R* F, bool with_K, double* sums) {
  __shared__ double part_sums[kPrepareSums][kColumnParts * kColumnFrames];  // one column per thread
  const int t = static_cast<int>(threadIdx.x), part = t % kColumnParts;
  const int first = static_cast<int>(blockIdx.x) * kColumnFrames, i = first + t / kColumnParts;
  for (int k = 0; k < kPrepareSums; ++k) part_sums[k][t] = 0;
  if (i < m.frames)
    frame_prepare_pairs(m, f, F, i, part, kColumnParts, with_K,
                        [&](int k, double value) { part_sums[k][t] += value; });
  __syncthreads();
  // Entry e of frame first + e / kPrepareSums, summed over the frame's parts in part order.
  for (int e = t; e < kColumnFrames * kPrepareSums; e += static_cast<int>(blockDim.x)) {
    const int fl = e / kPrepareSums, k = e - kPrepareSums * fl;
    if (first + fl >= m.frames) break;
    double sum = 0;
    for (int pp = 0; pp < kColumnParts; ++pp) sum += part_sums[k][kColumnParts * fl + pp];
    sums[kPrepareSums * static_cast<size_t>(first) + e] = sum;
  }
}

template <class R>
__global__ void k_frame_finish(ModelView<R> m, FrameView<R> f, const double* sums, double inv_h2, R* geo,
                               R* inertia_world, R* minv, double* diag, double k_scale, const double* load_rot,
                               bool precondition, R* step_block) {
  const int t = static_cast<int>(threadIdx.x), c = t % 6;
  const int i = static_cast<int>(blockIdx.x) * kFinishFrames + t / 6;
  if (t >= 6 * kFinishFrames || i >= m.frames) return;
  double K[36];
  Mat3 Kr;
  unpack_prepare_sums(sums + kPrepareSums * static_cast<size_t>(i), K, Kr);
  const bool lead = c == 0;
  frame_prepare_blocks(m, f, i, K, Kr, inv_h2, lead ? geo : nullptr, lead ? inertia_world : nullptr,
                       lead ? diag : nullptr, k_scale, load_rot, precondition, lead ? step_block : nullptr);
  const unsigned char* fixed = m.fixed + 6 * i;
  const BlockJacobiFactor factor = precondition ? block_jacobi_factor(fixed, K) : BlockJacobiFactor{};
  frame_preconditioner_column(fixed, K, factor, precondition, i, c, minv);
}

template <class R>
FASCIA_HD void block_jacobi(const R* minv, const R* r, int i, double* z) {
  for (int a = 0; a < 6; ++a) {
    double acc = 0;
    for (int b = 0; b < 6; ++b)
      acc += static_cast<double>(minv[kMinvValues * i + minv_index(a, b)]) * static_cast<double>(r[6 * i + b]);
    z[a] = acc;
  }
}

// Right-hand side and start of the PCG: b = M v / h - dW + f_ext (fixed DOFs 0), x = 0, r = b,
// z = M^-1 r, p = z, rz = r . z.
template <class R>
__global__ void k_pcg_init(ModelView<R> m, const R* gradient, const R* inertia_world, const double* velocities,
                           const double* external, double inv_h, const R* minv, R* x, R* r, R* z, R* p, Reduction red) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  double dot = 0;
  if (i < m.frames) {
    double b[6];
    const double mass = static_cast<double>(m.masses[i]);
    const Vec3 w = ldm(inertia_world + 9 * i) * load3(velocities + 6 * i + 3);
    const double mv[6] = {mass * velocities[6 * i], mass * velocities[6 * i + 1], mass * velocities[6 * i + 2],
                          w.x, w.y, w.z};
    for (int k = 0; k < 6; ++k) {
      b[k] = inv_h * mv[k] - static_cast<double>(gradient[6 * i + k]) + (external ? external[6 * i + k] : 0.0);
      if (m.fixed[6 * i + k]) b[k] = 0;
      r[6 * i + k] = static_cast<R>(b[k]);
      x[6 * i + k] = R(0);
    }
    double zz[6];
    block_jacobi(minv, r, i, zz);
    for (int k = 0; k < 6; ++k) {
      z[6 * i + k] = static_cast<R>(zz[k]);
      p[6 * i + k] = static_cast<R>(zz[k]);
      dot += static_cast<double>(r[6 * i + k]) * static_cast<double>(static_cast<R>(zz[k]));
    }
  }
  reduce_and_finish(dot, red, Finish::init, 0);
}

// ---- persistent PCG ----

// Sum over the whole grid of every thread's v, returned to every thread of every block. Each
// block writes its shuffle-tree sum to partials[blockIdx.x]; after the grid barrier every block
// sums all partials in block order with the same tree, so all blocks hold the same bits and the
// result does not depend on scheduling. That sum is block_sum's over the strided partials (thread
// t: b = t, t + blockDim.x, ...). In blocks of at most 4 warps (MaxThreads, the kernel's bound)
// warp 0 forms it alone: lane l takes the place of threads l + 32 w of every warp w and loads
// their partials of Rounds strides at once (one round trip to the L2 for grids of up to Rounds
// blockDim.x blocks), the warps' shuffle trees are interleaved, and lane 0 adds the warps' sums in
// order. The same bits, one block barrier instead of three after the grid barrier, and the other
// warps go straight to the broadcast. Larger blocks keep block_sum (the interleaved sums would
// need a register pair per warp).
template <int MaxThreads, int Rounds = 1>
__device__ inline double grid_sum(double v, double* partials, cooperative_groups::grid_group& grid) {
  constexpr int kWarpsMax = MaxThreads / 32;
  __shared__ double total;
  const double block = block_sum(v);
  if (threadIdx.x == 0) partials[blockIdx.x] = block;
  grid.sync();
  if constexpr (kWarpsMax > 4) {
    const double t = block_sum(strided_partial_sum<Rounds>(partials, gridDim.x));
    if (threadIdx.x == 0) total = t;
  } else if (threadIdx.x < 32) {
    const unsigned warps = blockDim.x / 32;
    double s[kWarpsMax];
#pragma unroll
    for (int w = 0; w < kWarpsMax; ++w) s[w] = 0;
    // Rounds rounds of loads issued together, then added in round order (+ 0.0 past the grid
    // leaves the sums' bits alone): one L2 round trip for grids of up to Rounds blocks per thread.
    for (unsigned k = threadIdx.x; k < gridDim.x; k += Rounds * blockDim.x) {
      double round[Rounds][kWarpsMax];
#pragma unroll
      for (int j = 0; j < Rounds; ++j)
#pragma unroll
        for (int w = 0; w < kWarpsMax; ++w) {
          const unsigned b = k + j * blockDim.x + 32u * w;
          round[j][w] = w < warps && b < gridDim.x ? __ldcg(partials + b) : 0.0;
        }
#pragma unroll
      for (int j = 0; j < Rounds; ++j)
#pragma unroll
        for (int w = 0; w < kWarpsMax; ++w) s[w] += round[j][w];
    }
    // Thread 0 arrives from the grid barrier's spin: the warp reconverges first, so that the
    // shuffles do not take their slower diverged-warp path.
    __syncwarp();
    for (int o = 16; o > 0; o >>= 1)
#pragma unroll
      for (int w = 0; w < kWarpsMax; ++w) s[w] += __shfl_down_sync(0xffffffffu, s[w], o);
    if (threadIdx.x == 0) {
      double t = 0;
#pragma unroll
      for (int w = 0; w < kWarpsMax; ++w)
        if (w < warps) t += s[w];
      total = t;
    }
  }
  __syncthreads();
  return total;
}

// The whole PCG loop of a step in one cooperative launch, no launches and no host round trips.

// ---- persistent PCG with two grid barriers per iteration ----

// a b rounded once, never contracted with a following addition into a fused multiply-add, so
// that every kernel summing the same products gets the same bits.
__device__ inline double product_rn(double a, double b) { return __dmul_rn(a, b); }

// Frame terms of p . A p for one chunk of frame rows (chunk c: frames [c fpc, (c + 1) fpc), fpc =
// blockDim.x / 6, one thread per row): p_k (D p)_k with
// p = z + beta p_old formed as next_direction and D p = frame_row_of without sample terms (the
// rotational geometric and load blocks, inertia; 0 on fixed DOFs). Every thread must call it.
template <class R>
__device__ double frame_quadratic_chunk(const ModelView<R>& m, const R* geo, const R* inertia_world,
                                        const FrameTermsFlags& flags, const R* z, const R* p_old, double beta,
                                        int chunk) {
  __shared__ double dir[kRowThreadsMax];
  const int fpc = static_cast<int>(blockDim.x) / 6;
  const int t = static_cast<int>(threadIdx.x), i = chunk * fpc + t / 6, k = t - 6 * (t / 6);
  const bool active = t < 6 * fpc && i < m.frames;
  if (active) dir[t] = static_cast<double>(next_direction(z, p_old, beta, 6 * i + k));
  __syncthreads();
  double q = 0;
  if (active)
    q = product_rn(dir[t], frame_row_of(m, geo, inertia_world, flags.inv_h2, flags.project, dir + (t - k), i, k, 0.0,
                                        flags.k_scale));
  __syncthreads();
  return q;
}

// Frame phase of the two-barrier PCG, one thread per frame row (chunks as frame_quadratic_chunk):
// p = z + beta p stored, Ap = H p (k_frame_sums' arithmetic per row), then x += alpha p,
// r -= alpha Ap, z = M^-1 r (update_rows_chunk's arithmetic). Returns this thread's r_k z_k. Every thread of the
// block must call it.
template <class R>
__device__ double frame_update_chunk(const ModelView<R>& m, const R* slot_partials, const R* geo,
                                     const R* inertia_world, const FrameTermsFlags& flags, const R* minv, R* x, R* r,
                                     R* z, R* p, R* Ap, double beta, double alpha, int chunk) {
  __shared__ double dir[kRowThreadsMax];
  __shared__ double res[kRowThreadsMax];
  const int fpc = static_cast<int>(blockDim.x) / 6;
  const int t = static_cast<int>(threadIdx.x), i = chunk * fpc + t / 6, k = t - 6 * (t / 6);
  const bool active = t < 6 * fpc && i < m.frames;
  const int j = 6 * i + k;
  if (active) dir[t] = static_cast<double>(next_direction(z, p, beta, j));
  __syncthreads();
  UpdatedRow<R> u{};
  if (active) {
    p[j] = static_cast<R>(dir[t]);
    double acc = 0;
    for (int q = m.frame_slot_offsets[i]; q < m.frame_slot_offsets[i + 1]; ++q)
      acc += static_cast<double>(slot_partials[6 * m.frame_slots[q] + k]);
    const R apj = static_cast<R>(
        frame_row_of(m, geo, inertia_world, flags.inv_h2, flags.project, dir + (t - k), i, k, acc, flags.k_scale));
    Ap[j] = apj;
    u = update_row(x[j], r[j], alpha, dir[t], static_cast<double>(apj));
  }
  return store_and_precondition_row(active, u, minv, i, k, t, x, r, z, res);
}

// The PCG loop of the coalesced pass in one cooperative launch with two grid barriers per
// iteration. p . A p is summed in the sample phase, as
// k_scale sum_s v dF : dP (the coalesced pass returns it per sample) plus the frame terms
// frame_quadratic_chunk: equal to p . (A p) in exact arithmetic, since A p = k_scale sum_s v B_s^T dP_s
// plus the frame terms, and p is zero on fixed DOFs (z is, and p starts as z). So alpha is known
// after the barrier that ends the sample phase, and the frame phase applies the update at once:
//   (1) samples on p = z + beta p_old formed on the fly, slot partials; p . A p  -> barrier
//   (2) frames: p stored, A p, x += alpha p, r -= alpha A p, z = M^-1 r; r . z   -> barrier
// Every block sums the per-block partials in block order itself (grid_sum), so all blocks hold the
// same scalars and take the same branches; results are deterministic. `partials` holds 2
// gridDim.x doubles. Starts from k_pcg_init's scalars.
template <class R, int Keep>
__global__ void __launch_bounds__(kRowThreadsMax)
    k_pcg_two_barrier(ModelView<R> m, FrameView<R> f, int slot_lanes, const R* geo, const R* inertia_world,
                      FrameTermsFlags flags, const R* minv, R* x, R* r, R* z, R* p, R* Ap, R* slot_partials,
                      double* partials, Scalars* scalars, int max_iterations, double tolerance) {
  cooperative_groups::grid_group grid = cooperative_groups::this_grid();
  extern __shared__ unsigned char shared_raw[];
  R* local = reinterpret_cast<R*>(shared_raw);
  const double rz0 = scalars->rz0;
  double rz = scalars->rz, beta = 0;
  int done = scalars->done, it = 0;
  const int fpc = static_cast<int>(blockDim.x) / 6, chunks = (m.frames + fpc - 1) / fpc;
  while (done == 0 && it < max_iterations) {
    // (1) samples and the frame terms of p . A p.
    double part = 0;
    for (int b = blockIdx.x; b < m.blocks; b += gridDim.x) {
      part += flags.k_scale * ell_tangent_block<R, Keep>(m, f, z, p, beta, b, slot_lanes, local, slot_partials);
      __syncthreads();
    }
    for (int c = blockIdx.x; c < chunks; c += gridDim.x)
      part += frame_quadratic_chunk(m, geo, inertia_world, flags, z, p, beta, c);
    const double pAp = grid_sum<kRowThreadsMax>(part, partials, grid);
    if (!(pAp > 0 && pAp < HUGE_VAL)) {
      done = 2;
      break;
    }
    const double alpha = rz / pAp;
    // (2) frames: direction, A p, update, preconditioner.
    double dot = 0;
    for (int c = blockIdx.x; c < chunks; c += gridDim.x)
      dot += frame_update_chunk(m, slot_partials, geo, inertia_world, flags, minv, x, r, z, p, Ap, beta, alpha, c);
    const double rz_new = grid_sum<kRowThreadsMax>(dot, partials + gridDim.x, grid);
    end_iteration(rz_new, rz0, tolerance, rz, beta, it, done);
  }
  if (blockIdx.x == 0 && threadIdx.x == 0) store_progress(scalars, rz, beta, it, done);
}

// ---- persistent PCG with the loop invariants in registers (coalesced pass, small models) ----

// Threads per block of k_pcg_resident (the 128-sample blocks, one thread per sample), and the
// blocks per multiprocessor its registers must allow: 34,848 samples need 336 blocks, 3 per SM on
// a 132-SM device (at most 170 registers per thread).
constexpr int kResidentThreads = 128;
constexpr int kResidentBlocksPerSM = 3;
constexpr int kResidentSlots = 8;      // slots per frame held in registers (more are read each iteration)

// k_pcg_two_barrier's iteration where every block holds at most one sample block (one sample per
// thread) and one chunk of frame rows, so that what does not change during the PCG is read once:
// per sample its pairs' frames, slot-major positions, w and g, and v; per frame row its slots, its
// row of the preconditioner, of the frame block and inertia, and its values of x and r. Each
// iteration then reads only the directions z, p of the sample's frames and the slot partials of
// the row's frame, and writes p, z and the slot partials. With InRegisters (single precision)
// all of it sits in registers, with H = F - I, the material cache and the levers M = a g^T + w R;
// without (double, where that would spill), w, g and the frame rows' terms sit in shared memory
// (component-major, one word per thread: no bank conflicts), and the levers and the material are
// formed again each iteration from the lever records and the samples' state (cache hits), as
// k_pcg_two_barrier does. StagedFrames: at the start of each iteration the block's threads form
// its slots' directions p_i together in shared memory after the pair outputs, and without
// InRegisters the block's frames' lever records are copied there once (kLeverRecord values per
// slot) and the levers formed from there, and its samples' materials (law, lambda, mu, density)
// are held there too, instead of each pair gathering them from global memory and each sample
// reading its material through its index (every grid barrier invalidates the L1, so those loads
// go to the L2, one after another). The same arithmetic as k_pcg_two_barrier, except that each slot
// is summed by one thread. Requires at most MaxPairs pairs per sample and grid = max(sample
// blocks, frame chunks). Models without an hgo material only: its fibre terms and uncoupled
// form would spill the double kernel's registers and slow the single one (those models run
// k_pcg_two_barrier).
constexpr int kResidentRowTerms = 13;  // [minv row (6), frame block row (3), inertia row (3), mass]

template <class R, int MaxPairs, bool InRegisters, bool StagedFrames = false>
__global__ void __launch_bounds__(kResidentThreads, kResidentBlocksPerSM)
    k_pcg_resident(ModelView<R> m, FrameView<R> f, const R* geo, const R* inertia_world, FrameTermsFlags flags,
                   const R* minv, R* x, R* r, R* z, R* p, R* Ap, R* slot_partials, double* partials,
                   Scalars* scalars, int max_iterations, double tolerance) {
  cooperative_groups::grid_group grid = cooperative_groups::this_grid();
  extern __shared__ unsigned char shared_raw[];
  R* local = reinterpret_cast<R*>(shared_raw);
  __shared__ double dir[kResidentThreads];
  __shared__ double res[kResidentThreads];
  __shared__ double row_held[InRegisters ? 1 : kResidentRowTerms * kResidentThreads];
  __shared__ R pair_held[InRegisters ? 1 : 4 * MaxPairs * kResidentThreads];  // [w, g (3)] per pair
  __shared__ unsigned short slot_held[StagedFrames ? MaxPairs * kResidentThreads : 1];  // block-local slot per pair
  // StagedFrames without InRegisters: the sample's material [lambda, mu, density] and law.
  constexpr bool kMaterialHeld = StagedFrames && !InRegisters;
  __shared__ double material_held[kMaterialHeld ? 3 * kResidentThreads : 1];
  __shared__ MaterialLaw law_held[kMaterialHeld ? kResidentThreads : 1];
  const auto held = [&](auto* a, int c) -> auto& { return a[c * kResidentThreads + static_cast<int>(threadIdx.x)]; };
  const int b = static_cast<int>(blockIdx.x), tid = static_cast<int>(threadIdx.x);
  // grid_sum's rounds of loads issued together: all of a grid of 3 blocks per SM where registers
  // allow (with the levers held in registers, more rounds spill).
  constexpr int kResidentSumRounds = InRegisters ? 1 : 3;

  // Sample block b, sample tid.
  const bool has_block = b < m.blocks;
  int s0 = 0, ns = 0, stride = 0, q0 = 0, q1 = 0, base = 0, e0 = 0;
  if (has_block) {
    s0 = m.block_samples[b];
    ns = m.block_samples[b + 1] - s0;
    stride = m.offsets[s0 + ns] - m.offsets[s0];
    q0 = m.block_slots[b];
    q1 = m.block_slots[b + 1];
    base = m.slot_pair_offsets[q0];
    e0 = m.ell_offsets[b];
  }
  const bool has_sample = has_block && tid < ns;
  const int s = s0 + tid;
  int count = 0;
  R v = 0;
  Mat3T<R> F = zero3<R>();
  MaterialCacheT<R> cache{zero3<R>(), R(0)};
  Material mat{};
  Vec3T<R> ps{0, 0, 0};
  EllEntry<R> entry[MaxPairs] = {};
  Mat3T<R> lever[InRegisters ? MaxPairs : 1] = {};
  if (has_sample) {
    count = m.offsets[s + 1] - m.offsets[s];
    ps = Vec3T<R>{sample_value(f.sample_state, m.samples, 0, s), sample_value(f.sample_state, m.samples, 1, s),
                  sample_value(f.sample_state, m.samples, 2, s)};
    v = sample_value(f.sample_state, m.samples, 3, s);
    if constexpr (InRegisters) {
      mat = m.materials[m.sample_materials[s]];
      ell_sample_material(m, f.sample_state, s, F, cache);
    }
    if constexpr (kMaterialHeld) {
      const Material own = m.materials[m.sample_materials[s]];
      held(law_held, 0) = own.law;
      held(material_held, 0) = own.lambda;
      held(material_held, 1) = own.mu;
      held(material_held, 2) = own.density;
    }
#pragma unroll
    for (int j = 0; j < MaxPairs; ++j)
      if (j < count) {
        entry[j] = ell_entry(m, e0 + j * ns + tid);
        if constexpr (InRegisters) {
          lever[j] = ell_pair_of(entry[j], f.levers, ps).M;
        } else {
          held(pair_held, 4 * j) = entry[j].w;
          held(pair_held, 4 * j + 1) = entry[j].g.x;
          held(pair_held, 4 * j + 2) = entry[j].g.y;
          held(pair_held, 4 * j + 3) = entry[j].g.z;
        }
        if constexpr (StagedFrames) held(slot_held, j) = m.ell_slot[e0 + j * ns + tid];
      }
  }
  // StagedFrames: the lever records [R_i, x̄_i] of the block's slots after the pair outputs (not
  // with InRegisters, which holds the levers), then their directions p_i (6 values per slot, formed
  // at the start of each iteration), then their frames' indices.
  R* lever_records = local + slot_records_offset(stride);
  R* slot_dirs = lever_records + (InRegisters ? 0 : kLeverRecord * (q1 - q0));
  int* slot_frame_held = reinterpret_cast<int*>(slot_dirs + 6 * (q1 - q0));  // the slots' frames
  if constexpr (StagedFrames) {
    for (int q = tid; q < q1 - q0; q += static_cast<int>(blockDim.x)) slot_frame_held[q] = m.slot_frames[q0 + q];
    if constexpr (!InRegisters) {
      for (int idx = tid; idx < kLeverRecord * (q1 - q0); idx += static_cast<int>(blockDim.x)) {
        const int q = idx / kLeverRecord, c = idx - kLeverRecord * q;
        lever_records[idx] = f.levers[kLeverRecord * static_cast<size_t>(m.slot_frames[q0 + q]) + c];
      }
    }
    __syncthreads();
  }

  // Frame rows of chunk b.
  const int fpc = static_cast<int>(blockDim.x) / 6, chunks = (m.frames + fpc - 1) / fpc;
  const int i = b * fpc + tid / 6, k = tid - 6 * (tid / 6);
  const bool row = b < chunks && tid < 6 * fpc && i < m.frames;
  const int jrow = 6 * i + k;
  R xj = 0, rj = 0, zj = 0, pj = 0;
  double mrow[6] = {0, 0, 0, 0, 0, 0};
  FrameRowTerms terms;
  int slot[kResidentSlots] = {};
  int slot_begin = 0, slot_end = 0;
  if (row) {
    xj = x[jrow];
    rj = r[jrow];
    zj = z[jrow];
    pj = p[jrow];
    for (int c = 0; c < 6; ++c) mrow[c] = static_cast<double>(minv[kMinvValues * static_cast<size_t>(i) + minv_index(k, c)]);
    terms = frame_row_terms(m, geo, inertia_world, i, k);
    if constexpr (!InRegisters) {
      for (int c = 0; c < 6; ++c) held(row_held, c) = mrow[c];
      for (int c = 0; c < 3; ++c) held(row_held, 6 + c) = terms.geo[c];
      for (int c = 0; c < 3; ++c) held(row_held, 9 + c) = terms.inertia[c];
      held(row_held, 12) = terms.mass;
    }
    slot_begin = m.frame_slot_offsets[i];
    slot_end = m.frame_slot_offsets[i + 1];
#pragma unroll
    for (int n = 0; n < kResidentSlots; ++n)
      if (slot_begin + n < slot_end) slot[n] = m.frame_slots[slot_begin + n];
  }

  const double rz0 = scalars->rz0;
  double rz = scalars->rz, beta = 0;
  int done = scalars->done, it = 0;
  while (done == 0 && it < max_iterations) {
    // (1) samples on p = z + beta p_old, slot sums; p . A p.
    double part = 0;
    if constexpr (StagedFrames) {  // p of the block's slots, with next_direction's rounding
      // kDirRounds rounds of loads issued together (each round trip to the L2 is a wait: the grid
      // barrier emptied the L1), the frames' indices from shared memory.
      constexpr int kDirRounds = 3;
      for (int idx0 = tid; idx0 < 6 * (q1 - q0); idx0 += kDirRounds * static_cast<int>(blockDim.x)) {
        R zv[kDirRounds], pv[kDirRounds];
#pragma unroll
        for (int j = 0; j < kDirRounds; ++j) {
          const int idx = idx0 + j * static_cast<int>(blockDim.x), q = idx / 6, c = idx - 6 * q;
          if (idx < 6 * (q1 - q0)) {
            const int row = 6 * static_cast<int>(slot_frame_held[q]) + c;
            zv[j] = z[row];
            pv[j] = p[row];
          }
        }
#pragma unroll
        for (int j = 0; j < kDirRounds; ++j) {
          const int idx = idx0 + j * static_cast<int>(blockDim.x);
          if (idx < 6 * (q1 - q0)) slot_dirs[idx] = direction_value(zv[j], pv[j], beta);
        }
      }
      __syncthreads();
    }
    if (has_sample) {
      // Without InRegisters each half gathers the lever records again (cache hits), so that no
      // pair's lever is live across dP.
      const auto pair = [&](int j) {
        if constexpr (InRegisters) {
          return EllPair<R>{lever[j], entry[j].g, entry[j].i};
        } else {
          EllEntry<R> en = entry[j];
          en.w = held(pair_held, 4 * j);
          en.g = Vec3T<R>{held(pair_held, 4 * j + 1), held(pair_held, 4 * j + 2), held(pair_held, 4 * j + 3)};
          if constexpr (StagedFrames) {
            R rec[kLeverRecord];
            load_shared<kLeverRecord>(lever_records + kLeverRecord * static_cast<int>(held(slot_held, j)), rec);
            return ell_pair_from_record(en, rec, ps);
          } else {
            return ell_pair_of(en, f.levers, ps);
          }
        }
      };
      Mat3T<R> dF = zero3<R>();
#pragma unroll
      for (int j = 0; j < MaxPairs; ++j)
        if (j < count) {
          if constexpr (StagedFrames) {
            const EllPair<R> q = pair(j);
            R di[6];
            load_shared<6>(slot_dirs + 6 * static_cast<int>(held(slot_held, j)), di);
            dF += pair_lever_differential(Vec3T<R>{di[0], di[1], di[2]}, Vec3T<R>{di[3], di[4], di[5]}, q.g, q.M);
          } else {
            ell_pair_dF(pair(j), z, p, beta, dF);
          }
        }
      if constexpr (kMaterialHeld) {
        mat.law = held(law_held, 0);
        mat.lambda = held(material_held, 0);
        mat.mu = held(material_held, 1);
        mat.density = held(material_held, 2);
        ell_sample_material(m, f.sample_state, s, mat, F, cache);
      } else if constexpr (!InRegisters) {
        ell_sample_material(m, f.sample_state, s, F, cache);
        mat = m.materials[m.sample_materials[s]];
      }
      const Mat3T<R> dP = pk1_differential<R, false>(mat, F, cache, dF);
      part = flags.k_scale * (static_cast<double>(v) * static_cast<double>(ddot(dF, dP)));
#pragma unroll
      for (int j = 0; j < MaxPairs; ++j)
        if (j < count) ell_pair_output(pair(j), dP, v, entry[j].pos, stride, local);
    }
    __syncthreads();
    for (int qq = q0 + tid; qq < q1; qq += static_cast<int>(blockDim.x)) {
      const int a = m.slot_pair_offsets[qq] - base, e = m.slot_pair_offsets[qq + 1] - base;
      R acc[6] = {0, 0, 0, 0, 0, 0};
      for (int kk = a; kk < e; ++kk)
#pragma unroll
        for (int c = 0; c < 6; ++c) acc[c] += local[c * stride + kk];
      for (int c = 0; c < 6; ++c) slot_partials[6 * static_cast<size_t>(qq) + c] = acc[c];
    }
    if (row) dir[tid] = static_cast<double>(direction_value(zj, pj, beta));
    __syncthreads();
    if constexpr (!InRegisters) {
      if (row) {
        for (int c = 0; c < 3; ++c) terms.geo[c] = held(row_held, 6 + c);
        for (int c = 0; c < 3; ++c) terms.inertia[c] = held(row_held, 9 + c);
        terms.mass = held(row_held, 12);
      }
    }
    if (row)
      part += product_rn(dir[tid],
                         apply_frame_row(terms, flags.inv_h2, flags.project, dir + (tid - k), k, 0.0, flags.k_scale));
    const double pAp = grid_sum<kResidentThreads, kResidentSumRounds>(part, partials, grid);
    if (!(pAp > 0 && pAp < HUGE_VAL)) {
      done = 2;
      break;
    }
    const double alpha = rz / pAp;
    // (2) frames: p stored, A p, update, preconditioner (frame_update_chunk's arithmetic).
    double dot = 0;
    if (row) {
      pj = direction_value(zj, pj, beta);
      p[jrow] = pj;
      // The held slots' partials loaded together, then summed in slot order (loaded and added one
      // by one, each would wait for a round trip to the L2).
      R held_partials[kResidentSlots];
#pragma unroll
      for (int n = 0; n < kResidentSlots; ++n)
        held_partials[n] = slot_begin + n < slot_end ? slot_partials[6 * static_cast<size_t>(slot[n]) + k] : R(0);
      double acc = 0;
#pragma unroll
      for (int n = 0; n < kResidentSlots; ++n)
        if (slot_begin + n < slot_end) acc += static_cast<double>(held_partials[n]);
      for (int n = slot_begin + kResidentSlots; n < slot_end; ++n)
        acc += static_cast<double>(slot_partials[6 * static_cast<size_t>(m.frame_slots[n]) + k]);
      const R apj = static_cast<R>(apply_frame_row(terms, flags.inv_h2, flags.project, dir + (tid - k), k, acc,
                                                   flags.k_scale));
      Ap[jrow] = apj;
      const UpdatedRow<R> u = update_row(xj, rj, alpha, static_cast<double>(pj), static_cast<double>(apj));
      xj = u.x;
      rj = u.r;
      res[tid] = static_cast<double>(rj);
    }
    __syncthreads();
    if (row) {
      zj = static_cast<R>(preconditioned_row(
          [&](int c) { return InRegisters ? mrow[c] : held(row_held, c); }, res + (tid - k)));
      z[jrow] = zj;
      dot = static_cast<double>(rj) * static_cast<double>(zj);
    }
    const double rz_new = grid_sum<kResidentThreads, kResidentSumRounds>(dot, partials + gridDim.x, grid);
    end_iteration(rz_new, rz0, tolerance, rz, beta, it, done);
  }
  if (row) {
    x[jrow] = xj;
    r[jrow] = rj;
  }
  if (b == 0 && tid == 0) store_progress(scalars, rz, beta, it, done);
}

// x <- x (+) delta, v <- delta / h (DESIGN.md: retract with world-axis rotation increments).
template <class R>
__global__ void k_step_update(int n, bool rotations_locked, double inv_h, const R* delta, double* positions,
                              double* orientations, double* velocities) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  double dl[6];
  for (int k = 0; k < 6; ++k) dl[k] = static_cast<double>(delta[6 * i + k]);
  for (int k = 0; k < 3; ++k) positions[3 * i + k] += dl[k];
  if (!rotations_locked)
    store_quat(orientations + 4 * i, apply_increment(load_quat(orientations + 4 * i), Vec3{dl[3], dl[4], dl[5]}));
  for (int k = 0; k < 6; ++k) velocities[6 * i + k] = inv_h * dl[k];
}

}  // namespace fascia::gpu
