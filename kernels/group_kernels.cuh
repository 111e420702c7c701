// The grouped tangent pass's kernel (group_pass.hpp): one block of kGroupBlock groups of
// kGroupLanes threads, the view `m` over the blocks of groups (ModelView, grouped fields).
#pragma once

#include <climits>

#include "elasticity_kernels.cuh"
#include "group_pass.hpp"

namespace fascia::gpu {

// Blocks per multiprocessor the kernel is compiled for (registers within 65,536 / (128 blocks));
// float keeps each sample's w and g in registers between the two halves, double reads them again.
template <class R>
constexpr int group_blocks_per_sm() {
  return sizeof(R) == sizeof(float) ? 5 : 3;
}

// One exchange of the reduce-scatter across a group's threads at distance `o`: the thread keeps
// the upper half where `upper_mine` (its lane's bit o is set), else the lower, adds its partner's
// copy of that half, and sends its partner the other.
template <class R, int n>
__device__ inline void group_exchange(const R* lower, const R* upper, bool upper_mine, int o, R* kept) {
#pragma unroll
  for (int c = 0; c < n; ++c) {
    const R send = upper_mine ? lower[c] : upper[c];
    const R keep = upper_mine ? upper[c] : lower[c];
    kept[c] = keep + __shfl_xor_sync(0xffffffffu, send, o);
  }
}

// w and g of entry (block b, frame k, block thread t) of group_data (group_data_index).
template <class R>
__device__ inline void group_data_entry(const ModelView<R>& m, int b, int k, int t, R& w, Vec3T<R>& g) {
  const long long e = group_data_index(b, k, t), E = m.group_entries;
  R v[4];
  if constexpr (sizeof(R) == sizeof(float))
    load_aligned<4>(m.group_data + group_data_offset<R>(e, 0, E), v);  // the entry's 4 values together
  else
    for (int c = 0; c < 4; ++c) v[c] = m.group_data[group_data_offset<R>(e, c, E)];
  w = v[0];
  g = Vec3T<R>{v[1], v[2], v[3]};
}

// A block's slots [q0, q1) and its outputs' first slot-major position (base) and count (stride).
struct BlockSlots {
  int q0 = 0, q1 = 0, base = 0, stride = 0;
};
template <class R>
__device__ inline BlockSlots block_slot_range(const ModelView<R>& m, int b) {
  BlockSlots bs;
  bs.q0 = m.block_slots[b];
  bs.q1 = m.block_slots[b + 1];
  bs.base = m.slot_pair_offsets[bs.q0];
  bs.stride = m.slot_pair_offsets[bs.q1] - bs.base;
  return bs;
}

// One slot of group_slot_sums: its positions [a, e) in the block's outputs and where its partials
// are stored (frame-major, m.slot_store); zero past the block's slots.
struct SlotBounds {
  int a = 0, e = 0, store = 0;
};
template <class R>
__device__ inline SlotBounds slot_bounds(const ModelView<R>& m, int q, int q1, int base) {
  SlotBounds sb;
  if (q < q1) {
    sb.a = m.slot_pair_offsets[q] - base;
    sb.e = m.slot_pair_offsets[q + 1] - base;
    sb.store = m.slot_store[q];
  }
  return sb;
}

// warp_slot_sums for the grouped pass (the same sums in the same order) over the block's slots
// [q0, q1) with the partials stored frame-major (m.slot_store); `first_bounds`: this thread's
// slot of the first round, where loaded beforehand (Preloaded), else loaded here.
template <bool Preloaded, class R>
__device__ void group_slot_sums(const ModelView<R>& m, const R* outs, int stride, const SlotBounds& first_bounds,
                                int q0, int q1, int base, int slot_lanes, R* slot_partials) {
  const int lane = static_cast<int>(threadIdx.x) & (slot_lanes - 1);
  const int group = static_cast<int>(threadIdx.x) / slot_lanes, groups = static_cast<int>(blockDim.x) / slot_lanes;
  for (int first = q0; first < q1; first += groups) {  // the same trip count in every thread
    const int q = first + group;
    const SlotBounds sb = Preloaded && first == q0 ? first_bounds : slot_bounds(m, q, q1, base);
    slot_sum_store(outs, stride, sb.a, sb.e, q < q1, lane, slot_lanes, slot_partials + 6 * static_cast<size_t>(sb.store));
  }
}

// Tangent sample pass, grouped (ModelView's grouped fields; `d` as k_ell_tangent): per group its frames' records into shared memory, per thread its sample's dF,
// dP and pair outputs; the outputs of each frame summed across the group's threads by a
// reduce-scatter (exchanges at distance 4, 2, 1: group_lane_sum's order), in two halves of 4
// frames (24 values live); each (group, frame) entry's sum into shared memory at its slot-major
// position, then `slot_lanes` lanes per slot sum the block's slots (group_slot_sums). Fibres =
// false (models without an hgo material) leaves the fibre code out: compiled in, it spills the
// single-precision kernel's registers (4.18 M samples x 8 on an H100: 0.72 ms per CG iteration
// against 0.54).
template <class R, bool Fibres>
__global__ void __launch_bounds__(kGroupThreads, group_blocks_per_sm<R>())
    k_group_tangent(ModelView<R> m, FrameView<R> f, const R* d, R* slot_partials, int slot_lanes) {
  constexpr bool kKeepEntries = sizeof(R) == sizeof(float);
  __shared__ __align__(16) R records[kGroupRecords];
  __shared__ __align__(16) R outs[6 * kGroupThreads];
  const int b = static_cast<int>(blockIdx.x), t = static_cast<int>(threadIdx.x);
  const int gl = t / kGroupLanes, lane = t % kGroupLanes;
  const int g = b * kGroupBlock + gl;  // blocks of kGroupBlock consecutive groups (group_layout.hpp)
  const bool group_active = g < m.group_count;
  const bool up4 = (lane & 4) != 0, up2 = (lane & 2) != 0, up1 = (lane & 1) != 0;
  // The loads that depend on nothing else, issued together: the group's frame `lane`, first
  // sample and the slot-major positions this thread stores (frames kh and kh + 4 of the group,
  // group_exchange's split) and the block's slot range.
  const int kh = (up4 ? 2 : 0) + (up2 ? 1 : 0);
  const size_t entry = kGroupLanes * static_cast<size_t>(g);
  const int frame = group_active ? m.group_frames[entry + lane] : -1;
  const int s0 = group_active ? m.group_samples[g] : 0, s1 = group_active ? m.group_samples[g + 1] : 0;
  // Float also loads here what the outputs and the slot sums need (positions, the block's slots);
  // double, where registers are short, loads them there.
  constexpr bool kPreload = sizeof(R) == sizeof(float);
  BlockSlots bs;
  if constexpr (kPreload) bs = block_slot_range(m, b);
  int pos[2] = {0, 0};
  if (kPreload && group_active) {
    pos[0] = m.group_pos[entry + kh];
    pos[1] = m.group_pos[entry + kh + 4];
  }
  // Then every global load of the dF half and the material, so that their latencies overlap:
  // thread `lane` gathers its group's frame `lane` (lever record, direction) and reads its
  // group's sample `lane` (position, w and g of its pairs, H and the material cache); and the
  // block's slot-sum bounds (group_slot_sums).
  R* rec = records + gl * kGroupSlotStride * kGroupRecord;  // the group's frame k at rec + k kGroupRecord
  R lever[kLeverRecord], di[6];
  if (frame >= 0) {
    load_aligned<kLeverRecord>(f.levers + kLeverRecord * static_cast<size_t>(frame), lever);
    load_six(d, frame, di);
  }
  // The group's frame count: its threads' bits of the warp's ballot (frames come first).
  const unsigned present = __ballot_sync(0xffffffffu, frame >= 0);
  const int n = __popc((present >> (t & 31 & ~(kGroupLanes - 1))) & ((1u << kGroupLanes) - 1));
  const bool active = group_active && lane < s1 - s0;
  const int s = s0 + lane;
  SlotBounds bounds;  // this thread's slot of the first round of the slot sums
  if constexpr (kPreload) bounds = slot_bounds(m, bs.q0 + t / slot_lanes, bs.q1, bs.base);
  Vec3T<R> ps{0, 0, 0};
  R w[kGroupLanes];
  Vec3T<R> gr[kGroupLanes];
  const auto load_entry = [&](int k, R& wk, Vec3T<R>& gk) { group_data_entry(m, b, k, t, wk, gk); };
  // Double reads the samples' state evict-first (sample_value<true>: each value is read once per
  // pass), which leaves the caches to the frame records and w and g; single keeps the default
  // loads, with which it is the faster.
  constexpr bool kStateOnce = sizeof(R) == sizeof(double);
  Mat3T<R> F = zero3<R>();
  MaterialCacheT<R> cache{};
  const Material* mat = nullptr;
  if (active) {
    ps = Vec3T<R>{sample_value<kStateOnce>(f.sample_state, m.samples, 0, s),
                  sample_value<kStateOnce>(f.sample_state, m.samples, 1, s),
                  sample_value<kStateOnce>(f.sample_state, m.samples, 2, s)};
#pragma unroll
    for (int k = 0; k < kGroupLanes; ++k)
      if (k < n) load_entry(k, w[k], gr[k]);
    mat = &m.materials[m.sample_materials[s]];
    ell_sample_material<kStateOnce>(m, f.sample_state, s, *mat, F, cache);
  }
  if (frame >= 0) group_frame_record(lever, di, rec + lane * kGroupRecord);
  __syncwarp();
  Mat3T<R> dF = zero3<R>(), dP = zero3<R>();  // dP: v dP
  if (active) {
#pragma unroll
    for (int k = 0; k < kGroupLanes; ++k)
      if (k < n) group_pair_dF(rec + k * kGroupRecord, ps, w[k], gr[k], dF);
    dP = sample_value<kStateOnce>(f.sample_state, m.samples, 3, s) * pk1_differential<R, Fibres>(*mat, F, cache, dF);
  }
  if constexpr (!kPreload) bs = block_slot_range(m, b);
  const int stride = bs.stride;
#pragma unroll
  for (int half = 0; half < 2; ++half) {
    R o[4][6];
#pragma unroll
    for (int kk = 0; kk < 4; ++kk) {
      const int k = 4 * half + kk;
      if (active && k < n) {
        R wk = 0;
        Vec3T<R> gk{0, 0, 0};
        if constexpr (kKeepEntries) {
          wk = w[k];
          gk = gr[k];
        } else {
          load_entry(k, wk, gk);
        }
        group_pair_output(rec + k * kGroupRecord, ps, wk, gk, dP, o[kk]);
      } else {
#pragma unroll
        for (int c = 0; c < 6; ++c) o[kk][c] = R(0);
      }
    }
    // Frames 4 half + {0, 1} (lower) or {2, 3} (upper), then one of them, then 3 of its 6 values.
    R pair[2][6], one[6], three[3];
    group_exchange<R, 12>(&o[0][0], &o[2][0], up4, 4, &pair[0][0]);
    group_exchange<R, 6>(pair[0], pair[1], up2, 2, one);
    group_exchange<R, 3>(one, one + 3, up1, 1, three);
    const int c0 = up1 ? 3 : 0;
    if (group_active && 4 * half + kh < n) {
      const int at = kPreload ? pos[half] : m.group_pos[entry + 4 * half + kh];
#pragma unroll
      for (int c = 0; c < 3; ++c) outs[(c0 + c) * stride + at] = three[c];
    }
  }
  __syncthreads();
  group_slot_sums<kPreload>(m, outs, stride, bounds, bs.q0, bs.q1, bs.base, slot_lanes, slot_partials);
}

}  // namespace fascia::gpu
