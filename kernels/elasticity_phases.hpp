// The per-thread bodies of the CUDA elasticity kernels (paper §3.2), written as FASCIA_HD
// functions over raw device pointers so that the same code is compiled into the kernels
// (device_elasticity.cu) and can be stepped through on the host (tests/kernels).
//
// Storage precision is the template parameter R (double or float): the model tables, the frame
// kinematics and the product's direction and partial sums are stored in R. All arithmetic of one sample or frame runs in
// double registers through the shared mechanics of engine/ (frame_sample.hpp, material.hpp), so
// the single-precision build loses accuracy only where values are rounded to float in memory.
//
// The passes (docs/gpu.md): the force pass rebuilds F from the frames (a = R (p_s - x_i) from the
// rest positions, eq. 2 with rest orientation I), one thread per sample (fused_sample), and
// stores F, the material cache and the samples' state of the tangent product; each pair's
// 6-vector is summed per frame inside the thread block in shared memory in a fixed order
// ("slots"), and a frame pass sums the few block partials of each frame. The tangent product runs
// the coalesced pass (pairs in ELL order, below) or, where the samples share their frames in
// groups, the grouped pass (group_pass.hpp), with the same block and frame sums.
// Every sum runs in an order fixed by the model, with no atomics on data: deterministic.
#pragma once

#include "core/rotation.hpp"
#include "core/small_math.hpp"
#include "material/material.hpp"
#include "mechanics/frame_sample.hpp"

#include <type_traits>

namespace fascia::gpu {

template <class R>
FASCIA_HD Vec3 ld3(const R* p) {
  return Vec3{static_cast<double>(p[0]), static_cast<double>(p[1]), static_cast<double>(p[2])};
}
template <class R>
FASCIA_HD Mat3 ldm(const R* p) {
  Mat3 a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a.m[r][c] = static_cast<double>(p[3 * r + c]);
  return a;
}
template <class R>
FASCIA_HD void st3(R* p, const Vec3& v) {
  p[0] = static_cast<R>(v.x);
  p[1] = static_cast<R>(v.y);
  p[2] = static_cast<R>(v.z);
}
template <class R>
FASCIA_HD void stm(R* p, const Mat3& a) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) p[3 * r + c] = static_cast<R>(a.m[r][c]);
}

// The model on the device (uploaded once). Positions are stored relative to `origin` (the centre
// of the rest bounding box) so that float storage keeps the digits of small offsets.
template <class R>
struct ModelView {
  int samples = 0, frames = 0, pairs = 0;
  // Neighbour table (paper §3.1), CSR over samples.
  const int* offsets = nullptr;     // [S+1]
  const int* frame_of = nullptr;    // [P]
  const R* weights = nullptr;       // [P]
  const R* gradients = nullptr;     // [P][3] 1/m
  // Reverse table, CSR over frames.
  const int* rev_offsets = nullptr;   // [N+1]
  const int* rev_pairs = nullptr;     // [P]
  const int* pair_samples = nullptr;  // [P]
  // Samples and frames.
  const R* volumes = nullptr;          // [S] m^3
  const int* sample_materials = nullptr;  // [S]
  const Material* materials = nullptr;
  const R* sample_rest = nullptr;  // [S][3] m, minus origin
  const R* frame_rest = nullptr;   // [N][3] m, minus origin
  // Blocks of consecutive samples and their distinct frames ("slots").
  int blocks = 0;
  const int* block_samples = nullptr;       // [B+1]
  const int* block_slots = nullptr;         // [B+1] slots of block b: [block_slots[b], block_slots[b+1])
  const int* slot_frames = nullptr;         // [Q]
  const int* slot_pair_offsets = nullptr;   // [Q+1]
  const int* slot_pairs = nullptr;          // [P] pair index relative to the block's first pair
  const int* frame_slot_offsets = nullptr;  // [N+1]
  const int* frame_slots = nullptr;         // [Q]
  // Coalesced tangent pass: the pairs of each block in ELL order (sample_layout.hpp).
  int ell_entries = 0;                      // E
  const int* ell_offsets = nullptr;         // [B+1]
  const unsigned short* ell_slot = nullptr; // [E] block-local slot of the entry's pair
  const R* ell_data = nullptr;              // [4][E]: w, then the gradient's x, y, z (1/m); component-major
  const int* ell_frame = nullptr;           // [E] frame of the entry's pair (0 on padding)
  const unsigned short* ell_pos = nullptr;  // [E] slot-major position in the block
  // Grouped tangent pass (group_layout.hpp, group_pass.hpp), in the view of its own blocks, where
  // `blocks`, block_slots, slot_pair_offsets and frame_slot_offsets are those of its blocks of
  // groups (block b holds groups [kGroupBlock b, kGroupBlock (b + 1))), frame_slots is null
  // (slot_store) and the per-sample block and slot tables are not used.
  int group_count = 0;                         // G
  const int* group_samples = nullptr;          // [G+1] first sample of each group
  const int* group_frames = nullptr;           // [G][kGroupLanes] frames, -1 past the group's count
  const unsigned short* group_pos = nullptr;   // [G][kGroupLanes] slot-major position in the block
  // [Q] where slot q's partials are stored: frame-major, so that each frame's slots are contiguous
  // and frame_slots (then null) is not read (k_frame_sums: one dependent load fewer).
  const int* slot_store = nullptr;
  const R* group_data = nullptr;  // w, g (1/m) per block, frame k, thread (group_data_offset)
  long long group_entries = 0;
};

// Frame kinematics of the current state: R_i row-major and x_i - origin.
template <class R>
struct FrameView {
  const R* rotations = nullptr;  // [N][9]
  const R* positions = nullptr;  // [N][3]
  const R* levers = nullptr;     // [N][kLeverRecord] (tangent passes)
  // Tangent passes: the samples' state of the Newton iteration, [kSampleState][S].
  const R* sample_state = nullptr;
};

// ---- frames: kinematics ------------------------------------------------------------------------

FASCIA_HD void frame_kinematics(int i, const double* positions, const double* orientations, const double* origin,
                                double* x_out, double* r_out) {
  const Mat3 Ri = rotation_matrix(normalized(load_quat(orientations + 4 * i)));
  for (int k = 0; k < 3; ++k) x_out[k] = positions[3 * i + k] - origin[k];
  store_mat3(r_out, Ri);
}

// ---- force pass --------------------------------------------------------------------------------

// One sample of the force pass. F is rebuilt from the frames (eq. 8, l = p_s - x_i, eq. 2 with
// rest orientation I), P = P(F) (eq. 19); each pair's v B_p^T P (eq. 18) goes to
// local[6 (p - pair_base) + k] (shared memory on the device). Stores F [S][9] (frame preparation)
// and the material cache [S][10] (tangent passes), and P [S][9] where P_out is set (the
// rotational geometric blocks of a preparation without K_ii). Returns v psi(F). Lane `lane` of `lanes`
// (1 on the host) takes the sample's pairs lane, lane + lanes, ...: `sum_lanes(F)` adds the lanes'
// partial F (the device's butterfly), each lane writes its pairs' outputs, lane 0 stores F and the
// cache and returns the energy (the others 0).
template <class R, class SumLanes>
FASCIA_HD double fused_sample(const ModelView<R>& m, const FrameView<R>& f, int s, int pair_base, R* local, R* F_out,
                              R* cache_out, R* P_out, int lane, int lanes, SumLanes&& sum_lanes) {
  const Vec3 ps = ld3(m.sample_rest + 3 * s);
  const int begin = m.offsets[s], end = m.offsets[s + 1];
  Mat3 F = zero3();
  for (int p = begin + lane; p < end; p += lanes) {
    const int i = m.frame_of[p];
    const Mat3 Ri = ldm(f.rotations + 9 * i);
    const Vec3 a = Ri * (ps - ld3(m.frame_rest + 3 * i));
    F += outer(ld3(f.positions + 3 * i) + a, ld3(m.gradients + 3 * p)) + static_cast<double>(m.weights[p]) * Ri;
  }
  sum_lanes(F);
  const Material mat = m.materials[m.sample_materials[s]];
  const double v = static_cast<double>(m.volumes[s]);
  MaterialCache cache;
  const Mat3 P = first_piola(mat, F, cache);
  if (lane == 0) {
    stm(F_out + 9 * s, F);
    stm(cache_out + 10 * s, cache.a);
    cache_out[10 * s + 9] = static_cast<R>(cache.c);
    if (P_out) stm(P_out + 9 * s, P);
  }
  for (int p = begin + lane; p < end; p += lanes) {
    const int i = m.frame_of[p];
    const Mat3 Ri = ldm(f.rotations + 9 * i);
    const Vec3 a = Ri * (ps - ld3(m.frame_rest + 3 * i));
    double out[6];
    pair_virtual_work(P, a, ld3(m.gradients + 3 * p), static_cast<double>(m.weights[p]), Ri, v, out);
    R* dst = local + 6 * (p - pair_base);
    for (int k = 0; k < 6; ++k) dst[k] = static_cast<R>(out[k]);
  }
  return lane == 0 ? v * energy_density(mat, F) : 0.0;
}

// Sum of the pairs of block slot q (one frame of one block), in increasing pair order.
template <class R>
FASCIA_HD void fused_slot_sum(const ModelView<R>& m, const R* local, int q, R* partials) {
  double acc[6] = {0, 0, 0, 0, 0, 0};
  for (int k = m.slot_pair_offsets[q]; k < m.slot_pair_offsets[q + 1]; ++k) {
    const R* src = local + 6 * m.slot_pairs[k];
    for (int j = 0; j < 6; ++j) acc[j] += static_cast<double>(src[j]);
  }
  for (int j = 0; j < 6; ++j) partials[6 * q + j] = static_cast<R>(acc[j]);
}

// Frame i's sum of its block slots, in block order.
template <class R>
FASCIA_HD void fused_gather(const ModelView<R>& m, const R* partials, int i, double* acc) {
  for (int j = 0; j < 6; ++j) acc[j] = 0;
  for (int k = m.frame_slot_offsets[i]; k < m.frame_slot_offsets[i + 1]; ++k) {
    const R* src = partials + 6 * m.frame_slots[k];
    for (int j = 0; j < 6; ++j) acc[j] += static_cast<double>(src[j]);
  }
}

// ---- vector loads ------------------------------------------------------------------------------

// n values (a multiple of 4 floats or 2 doubles) from a 16-byte-aligned address into registers
// of type D (double, or the storage type): 16-byte loads through the read-only cache on the
// device, plain loads on the host.
template <int n, class D>
FASCIA_HD void load_aligned(const double* src, D* dst) {
#ifdef __CUDA_ARCH__
  const double2* v = reinterpret_cast<const double2*>(src);
#pragma unroll
  for (int k = 0; k < n / 2; ++k) {
    const double2 t = __ldg(v + k);
    dst[2 * k] = static_cast<D>(t.x);
    dst[2 * k + 1] = static_cast<D>(t.y);
  }
#else
  for (int k = 0; k < n; ++k) dst[k] = static_cast<D>(src[k]);
#endif
}
template <int n, class D>
FASCIA_HD void load_aligned(const float* src, D* dst) {
#ifdef __CUDA_ARCH__
  const float4* v = reinterpret_cast<const float4*>(src);
#pragma unroll
  for (int k = 0; k < n / 4; ++k) {
    const float4 t = __ldg(v + k);
    dst[4 * k] = static_cast<D>(t.x);
    dst[4 * k + 1] = static_cast<D>(t.y);
    dst[4 * k + 2] = static_cast<D>(t.z);
    dst[4 * k + 3] = static_cast<D>(t.w);
  }
#else
  for (int k = 0; k < n; ++k) dst[k] = static_cast<D>(src[k]);
#endif
}

// The 6 direction values of frame i into registers of type D (16-byte loads for double, 8-byte
// for float: [N][6] floats are 8-byte aligned).
template <class D>
FASCIA_HD void load_six(const double* src, int i, D* dst) {
  load_aligned<6>(src + 6 * i, dst);
}
template <class D>
FASCIA_HD void load_six(const float* src, int i, D* dst) {
#ifdef __CUDA_ARCH__
  const float2* v = reinterpret_cast<const float2*>(src + 6 * i);
#pragma unroll
  for (int k = 0; k < 3; ++k) {
    const float2 t = __ldg(v + k);
    dst[2 * k] = static_cast<D>(t.x);
    dst[2 * k + 1] = static_cast<D>(t.y);
  }
#else
  for (int k = 0; k < 6; ++k) dst[k] = static_cast<D>(src[6 * i + k]);
#endif
}

// ---- coalesced tangent pass ---------------------------------------------------------------------
// The tangent product's sample pass with every per-sample and per-pair load coalesced and all
// arithmetic in the storage precision R (float in single precision: twice the FP32 rate of FP64
// and half the bytes):
//  - pairs in the block's ELL order (sample_layout.hpp): pair j of block-local sample t sits at
//    entry e = e0 + j ns + t with its frame (ell_frame), w and g (ell_data [4][E]), so threads t
//    and t + 1 read neighbouring words;
//  - the samples' state of the Newton iteration component-major, [kSampleState][S]: p_s - origin,
//    v, H = F - I and the material cache (pack_sample_state, after the force pass);
//  - each pair's frame as one 16-byte-aligned lever record [R_i (9), x̄_i - origin (3)] read with
//    vector loads (write_lever_record, with the kinematics), the direction d_i with 8-byte loads.
// With the pair's lever M = a g^T + w R_i (pair_lever), dF_p = dx g^T + [dr]x M and
// B_p^T dP = [dP g, axial(M dP^T)] (frame_sample.hpp). Pair outputs go to shared memory
// [6][P_b] in the block's slot-major order (ell_pos), so that each slot's pairs are contiguous
// and a group of lanes sums a slot (elasticity_kernels.cuh, warp_slot_sums) without gathering
// positions, in the storage precision.
constexpr int kLeverRecord = 12;  // [R_i row-major (9), x̄_i - origin (3) m]
// [p_s - origin (3) m, v (1) m^3, H = F - I (9), material cache a (9), c (1)]. The displacement
// gradient H rather than F: the StVK stress is rebuilt from it as E = sym(H) + H^T H / 2 without
// the cancellation of F^T F - I, so float keeps the digits of small strains, and the StVK pass reads
// 13 values per sample instead of 23 (neo-Hookean: all 23).
constexpr int kSampleState = 23;

// Frame i's lever record from its kinematics (rot: R_i row-major).
template <class R>
FASCIA_HD void write_lever_record(const double* rot, const R* frame_rest, int i, R* levers) {
  R* rec = levers + kLeverRecord * i;
  for (int k = 0; k < 9; ++k) rec[k] = static_cast<R>(rot[k]);
  for (int k = 0; k < 3; ++k) rec[9 + k] = frame_rest[3 * i + k];
}

// Sample s's state [kSampleState][S] from the force pass's F [S][9] and cache [S][10] (H = F - I
// formed in double from the stored F: no rounding beyond F's own).
template <class R>
FASCIA_HD void pack_sample_state(const ModelView<R>& m, const R* F, const R* cache, int s, R* state) {
  const size_t S = static_cast<size_t>(m.samples);
  for (int k = 0; k < 3; ++k) state[k * S + s] = m.sample_rest[3 * static_cast<size_t>(s) + k];
  state[3 * S + s] = m.volumes[s];
  for (int k = 0; k < 9; ++k)
    state[(4 + k) * S + s] =
        static_cast<R>(static_cast<double>(F[9 * static_cast<size_t>(s) + k]) - (k % 4 == 0 ? 1.0 : 0.0));
  for (int k = 0; k < 10; ++k) state[(13 + k) * S + s] = cache[10 * static_cast<size_t>(s) + k];
}

// Component k of sample s's state. Once: the pass reads it once (the grouped pass), so on the
// device it is loaded evict-first (ld.global.cs) and leaves the caches to the data that is reused.
template <bool Once = false, class R>
FASCIA_HD R sample_value(const R* state, int samples, int k, int s) {
  const size_t at = static_cast<size_t>(k) * static_cast<size_t>(samples) + static_cast<size_t>(s);
#ifdef __CUDA_ARCH__
  if constexpr (Once) return __ldcs(state + at);
#endif
  return state[at];
}

// One ELL entry: the pair's frame, w and g (1/m), read once per tangent product and kept in
// registers for both halves of the pass.
template <class R>
struct EllEntry {
  int i;    // frame
  int pos;  // slot-major position in the block (ell_pos)
  R w;
  Vec3T<R> g;
};

// ELL entry e.
template <class R>
FASCIA_HD EllEntry<R> ell_entry(const ModelView<R>& m, int e) {
  const size_t E = static_cast<size_t>(m.ell_entries);
  return EllEntry<R>{m.ell_frame[e], static_cast<int>(m.ell_pos[e]), m.ell_data[e],
                     Vec3T<R>{m.ell_data[E + e], m.ell_data[2 * E + e], m.ell_data[3 * E + e]}};
}

// One pair of the coalesced pass: its frame, gradient and lever.
template <class R>
struct EllPair {
  Mat3T<R> M;   // lever a g^T + w R_i
  Vec3T<R> g;   // 1/m
  int i;        // frame
};

// The pair of an ELL entry for the sample at ps (p_s - origin) from its frame's lever record rec
// [R_i, x̄_i - origin]: a = R_i (p_s - x̄_i) and the lever formed.
template <class R>
FASCIA_HD EllPair<R> ell_pair_from_record(const EllEntry<R>& en, const R* rec, const Vec3T<R>& ps) {
  EllPair<R> q;
  q.i = en.i;
  Mat3T<R> Ri;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Ri.m[r][c] = rec[3 * r + c];
  const Vec3T<R> a = Ri * (ps - Vec3T<R>{rec[9], rec[10], rec[11]});
  q.g = en.g;
  q.M = pair_lever(a, q.g, en.w, Ri);
  return q;
}

// The pair of an ELL entry, the frame's lever record gathered from levers [N][kLeverRecord].
template <class R>
FASCIA_HD EllPair<R> ell_pair_of(const EllEntry<R>& en, const R* levers, const Vec3T<R>& ps) {
  R rec[kLeverRecord];
  load_aligned<kLeverRecord>(levers + kLeverRecord * static_cast<size_t>(en.i), rec);
  return ell_pair_from_record(en, rec, ps);
}

// Adds the pair's dF_p = dx g^T + [dr]x M (eq. 11) for the direction d_i.
template <class R>
FASCIA_HD void ell_pair_dF(const EllPair<R>& q, const R* d, Mat3T<R>& dF) {
  R di[6];
  load_six(d, q.i, di);
  dF += pair_lever_differential(Vec3T<R>{di[0], di[1], di[2]}, Vec3T<R>{di[3], di[4], di[5]}, q.g, q.M);
}

// The first element of the records a kernel stages in a block's shared memory after its pair
// outputs [6][pairs], rounded up to 16 bytes.
FASCIA_HD int slot_records_offset(int pairs) { return (6 * pairs + 3) / 4 * 4; }

// n values of a 16-byte-aligned record in shared memory (plain vector loads: __ldg is for global
// memory only): 16-byte vectors where n fills them, else 2-value ones.
template <int n, class R>
FASCIA_HD void load_shared(const R* src, R* dst) {
#ifdef __CUDA_ARCH__
  using Vec = std::conditional_t<sizeof(R) == sizeof(double), double2, std::conditional_t<n % 4 == 0, float4, float2>>;
  constexpr int width = sizeof(Vec) / sizeof(R);
  const Vec* v = reinterpret_cast<const Vec*>(src);
#pragma unroll
  for (int k = 0; k < n / width; ++k) {
    const Vec t = v[k];
    const R* c = reinterpret_cast<const R*>(&t);
#pragma unroll
    for (int l = 0; l < width; ++l) dst[width * k + l] = c[l];
  }
#else
  for (int k = 0; k < n; ++k) dst[k] = src[k];
#endif
}

// F and the material cache of sample s, of material mat, from its stored H = F - I: StVK rebuilds
// S from H (eq. 5, 19: E = sym(H) + H^T H / 2), neo-Hookean reads its cache.
// Once: as sample_value.
template <bool Once = false, class R>
FASCIA_HD void ell_sample_material(const ModelView<R>& m, const R* state, int s, const Material& mat, Mat3T<R>& F,
                                   MaterialCacheT<R>& c) {
  Mat3T<R> H;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) H.m[r][k] = sample_value<Once>(state, m.samples, 4 + 3 * r + k, s);
  F = identity3<R>() + H;
  if (mat.law == MaterialLaw::stvk) {
    const Mat3T<R> E = symmetric_part(H) + R(0.5) * (transpose(H) * H);
    c.a = stvk_stress_from_strain<R>(static_cast<R>(mat.lambda), static_cast<R>(mat.mu), E);
    c.c = 0;
  } else {
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) c.a.m[r][k] = sample_value<Once>(state, m.samples, 13 + 3 * r + k, s);
    c.c = sample_value<Once>(state, m.samples, 22, s);
  }
}

// The same with the sample's material read from the model.
template <class R>
FASCIA_HD void ell_sample_material(const ModelView<R>& m, const R* state, int s, Mat3T<R>& F, MaterialCacheT<R>& c) {
  ell_sample_material(m, state, s, m.materials[m.sample_materials[s]], F, c);
}

// dP = C[dF] (eq. 22-24) of sample s (ell_sample_material).
template <class R>
FASCIA_HD Mat3T<R> ell_sample_dP(const ModelView<R>& m, const R* state, int s, const Mat3T<R>& dF) {
  Mat3T<R> F;
  MaterialCacheT<R> c;
  ell_sample_material(m, state, s, F, c);
  return pk1_differential(m.materials[m.sample_materials[s]], F, c, dF);
}

// The pair's v B_p^T dP (eq. 21, 23, 25-26) into outs[k stride + pos] (pos its slot-major
// position, stride the block's pair count).
template <class R>
FASCIA_HD void ell_pair_output(const EllPair<R>& q, const Mat3T<R>& dP, R v, int pos, int stride, R* outs) {
  R out[6];
  pair_lever_virtual_work(dP, q.g, q.M, out);
  for (int k = 0; k < 6; ++k) outs[k * stride + pos] = v * out[k];
}

// The coalesced pass of one sample (host emulation of ell_tangent_block in
// elasticity_kernels.cuh): dF from every pair, dP, outputs [6][stride].
template <class R>
FASCIA_HD void ell_sample(const ModelView<R>& m, const FrameView<R>& f, const R* d, int s, int t, int ns, int e0,
                          int stride, R* outs) {
  const int count = m.offsets[s + 1] - m.offsets[s];
  const Vec3T<R> ps{sample_value(f.sample_state, m.samples, 0, s), sample_value(f.sample_state, m.samples, 1, s),
                    sample_value(f.sample_state, m.samples, 2, s)};
  Mat3T<R> dF = zero3<R>();
  for (int j = 0; j < count; ++j)
    ell_pair_dF(ell_pair_of(ell_entry(m, e0 + j * ns + t), f.levers, ps), d, dF);
  const Mat3T<R> dP = ell_sample_dP(m, f.sample_state, s, dF);
  const R v = sample_value(f.sample_state, m.samples, 3, s);
  for (int j = 0; j < count; ++j) {
    const EllEntry<R> en = ell_entry(m, e0 + j * ns + t);
    ell_pair_output(ell_pair_of(en, f.levers, ps), dP, v, en.pos, stride, outs);
  }
}

// Component c of the sum of one slot's outputs at slot-major positions [a, e) of outs [6][stride],
// in the order of `lanes` lanes (elasticity_kernels.cuh, warp_slot_sums): lane l adds positions
// a + l, a + l + lanes, ... in turn, then the lanes' sums are combined by an xor butterfly
// (distance lanes/2, ..., 1). On the host this emulates the lanes value for value, so its bits are
// the device's.
template <class R>
FASCIA_HD R slot_tree_sum(const R* outs, int stride, int a, int e, int c, int lanes) {
  R sums[32];
  for (int l = 0; l < lanes; ++l) {
    sums[l] = R(0);
    for (int k = a + l; k < e; k += lanes) sums[l] += outs[c * stride + k];
  }
  for (int o = lanes / 2; o > 0; o >>= 1) {
    R next[32];
    for (int l = 0; l < lanes; ++l) next[l] = sums[l] + sums[l ^ o];
    for (int l = 0; l < lanes; ++l) sums[l] = next[l];
  }
  return sums[0];
}

// ---- frames: the rest of the product ----------------------------------------------------------

// Row k of the tangent product from the gather of frame i's sample terms `acc`: for the rotation
// rows (k >= 3) plus the frame's rotational geometric block geo [N][9] (frame_prepare_pairs' Kr,
// row-major; null: none) times d_r, di the frame's 6 direction values.
template <class R, class D>
FASCIA_HD double frame_row(const R* geo, const D* di, int i, int k, double acc) {
  if (k < 3 || !geo) return acc;
  const R* row = geo + 9 * i + 3 * (k - 3);
  return acc + (static_cast<double>(row[0]) * static_cast<double>(di[3]) +
                static_cast<double>(row[1]) * static_cast<double>(di[4]) +
                static_cast<double>(row[2]) * static_cast<double>(di[5]));
}

constexpr int kPrepareSums = 45;  // a frame's prepared sums: [K_ii (36), Kr (9)]

// K_ii [36] (row-major) and Kr from a frame's prepared sums (frame_prepare_pairs' indices).
FASCIA_HD void unpack_prepare_sums(const double* sums, double* K, Mat3& Kr) {
  for (int k = 0; k < 36; ++k) K[k] = sums[k];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Kr.m[r][c] = sums[36 + 3 * r + c];
}

// Frame i's 6x6 diagonal block K_ii (material + geometric, the sample terms) and its rotational
// geometric block Kr (frame_sample.hpp), summed over the frame's reverse pairs rev_offsets[i] +
// part, + part + parts, ... in order, from F [S][9] of the gradient pass: every column from one
// gather and one first Piola stress per pair, a = R_i (p_s - x_i). `add(k, value)` receives each pair's terms in pair order,
// k < 36 for K_ii[k] (row-major: column c of row r at 6 r + c, the column of the unit displacement
// (c < 3) or rotation (c >= 3) along axis c % 3), 36 + 3 r + c for Kr[r][c]; without `with_K`
// (a preparation without the diagonal blocks) only Kr's, from the gradient pass's P [S][9] where
// `P_stored` is set.
template <class R, class Add>
FASCIA_HD void frame_prepare_pairs(const ModelView<R>& m, const FrameView<R>& f, const R* F, const R* P_stored, int i,
                                   int part, int parts, bool with_K, Add&& add) {
  const Mat3 Ri = ldm(f.rotations + 9 * i);
  for (int q = m.rev_offsets[i] + part; q < m.rev_offsets[i + 1]; q += parts) {
    const int p = m.rev_pairs[q];
    const int s = m.pair_samples[p];
    const Vec3 l = ld3(m.sample_rest + 3 * s) - ld3(m.frame_rest + 3 * i);
    const Vec3 a = Ri * l;
    const Vec3 g = ld3(m.gradients + 3 * p);
    const double w = static_cast<double>(m.weights[p]);
    const double v = static_cast<double>(m.volumes[s]);
    if (!with_K && P_stored) {
      const Mat3 Kr = pair_rotational_geometric_block(ldm(P_stored + 9 * s), a, g, w, Ri, v);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) add(36 + 3 * r + c, Kr.m[r][c]);
      continue;
    }
    const Material mat = m.materials[m.sample_materials[s]];
    const Mat3 Fs = ldm(F + 9 * s);
    MaterialCache cache;
    const Mat3 P = first_piola(mat, Fs, cache);
    const Mat3 Kr = pair_rotational_geometric_block(P, a, g, w, Ri, v);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) add(36 + 3 * r + c, Kr.m[r][c]);
    if (!with_K) continue;
    for (int c = 0; c < 6; ++c) {
      const Vec3 e{c % 3 == 0 ? 1.0 : 0.0, c % 3 == 1 ? 1.0 : 0.0, c % 3 == 2 ? 1.0 : 0.0}, none{0, 0, 0};
      const Mat3 dP = pk1_differential(
          mat, Fs, cache, pair_deformation_differential(c < 3 ? e : none, c < 3 ? none : e, a, g, w, Ri));
      double out[6];
      pair_virtual_work(dP, a, g, w, Ri, v, out);
      for (int r = 0; r < 6; ++r) add(6 * r + c, out[r]);
    }
  }
}

// The rest of a frame's preparation from its sums: K [36] row-major (the sample terms of K_ii) and
// Kr. Writes Kr to geo_out and K_ii = K + [0 0; 0 Kr] (= Elasticity::tangent_diagonal_blocks) to
// diag_out (both nullable).
template <class R>
FASCIA_HD void frame_prepare_blocks(int i, double* K, const Mat3& Kr, R* geo_out, double* diag_out) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) K[6 * (3 + r) + 3 + c] += Kr.m[r][c];
  if (geo_out) stm(geo_out + 9 * i, Kr);
  if (diag_out)
    for (int k = 0; k < 36; ++k) diag_out[36 * i + k] = K[k];
}

// Per-frame preparation of a Newton iteration by one thread (frame_prepare_pairs, then
// frame_prepare_blocks); the device spreads the pairs over threads (elasticity_kernels.cuh,
// k_frame_columns and k_frame_finish).
template <class R>
FASCIA_HD void frame_prepare(const ModelView<R>& m, const FrameView<R>& f, const R* F, int i, R* geo_out,
                             double* diag_out) {
  double sums[kPrepareSums] = {};
  frame_prepare_pairs(m, f, F, static_cast<const R*>(nullptr), i, 0, 1, true,
                      [&](int k, double value) { sums[k] += value; });
  double K[36];
  Mat3 Kr;
  unpack_prepare_sums(sums, K, Kr);
  frame_prepare_blocks(i, K, Kr, geo_out, diag_out);
}

}  // namespace fascia::gpu
