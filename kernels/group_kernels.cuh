// The grouped tangent pass's kernel (group_pass.hpp): one block of kGroupBlock groups of
// kGroupLanes threads, the view `m` over the blocks of groups (ModelView, grouped fields).
#pragma once

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
// the half `mine` (its bit o set: the upper half) and adds its partner's copy of it.
template <class R, int n>
__device__ inline void group_exchange(const R* lower, const R* upper, bool upper_mine, int o, R* kept) {
#pragma unroll
  for (int c = 0; c < n; ++c) {
    const R send = upper_mine ? lower[c] : upper[c];
    const R keep = upper_mine ? upper[c] : lower[c];
    kept[c] = keep + __shfl_xor_sync(0xffffffffu, send, o);
  }
}

// Tangent sample pass, grouped (ModelView's grouped fields; `d`, `p_old`, scalars as
// k_ell_tangent): per group its frames' records into shared memory, per thread its sample's dF,
// dP and pair outputs; the outputs of each frame summed across the group's threads by a
// reduce-scatter (exchanges at distance 4, 2, 1: group_lane_sum's order), in two halves of 4
// frames (24 values live); each (group, frame) entry's sum into shared memory at its slot-major
// position, then `slot_lanes` lanes per slot sum the block's slots (warp_slot_sums).
template <class R>
__global__ void __launch_bounds__(kGroupThreads, group_blocks_per_sm<R>())
    k_group_tangent(ModelView<R> m, FrameView<R> f, const R* d, const R* p_old, R* slot_partials, const Scalars* sc,
                    int slot_lanes) {
  constexpr bool kKeepEntries = sizeof(R) == sizeof(float);
  __shared__ __align__(16) R records[kGroupRecords];
  __shared__ __align__(16) R outs[6 * kGroupThreads];
  if (finished(sc)) return;
  const double beta = p_old ? sc->beta : 0.0;
  const int b = static_cast<int>(blockIdx.x), t = static_cast<int>(threadIdx.x);
  const int gl = t / kGroupLanes, lane = t % kGroupLanes;
  const int g = m.block_samples[b] + gl;
  const bool group_active = g < m.block_samples[b + 1];
  // Every global load of the dF half and the material first, so that their latencies overlap:
  // thread `lane` gathers its group's frame `lane` (lever record, direction) and reads its
  // group's sample `lane` (position, w and g of its pairs, H and the material cache).
  R* rec = records + gl * kGroupSlotStride * kGroupRecord;  // the group's frame k at rec + k kGroupRecord
  const int frame = group_active ? m.group_frames[kGroupLanes * static_cast<size_t>(g) + lane] : -1;
  R lever[kLeverRecord], di[6];
  if (frame >= 0) {
    load_aligned<kLeverRecord>(f.levers + kLeverRecord * static_cast<size_t>(frame), lever);
    load_six(d, frame, di);
    if (p_old) {
      R po[6];
      load_six(p_old, frame, po);
#pragma unroll
      for (int k = 0; k < 6; ++k) di[k] = direction_value(di[k], po[k], beta);
    }
  }
  // The group's frame count: its threads' bits of the warp's ballot (frames come first).
  const unsigned present = __ballot_sync(0xffffffffu, frame >= 0);
  const int n = __popc((present >> (t & 31 & ~(kGroupLanes - 1))) & ((1u << kGroupLanes) - 1));
  const int s0 = group_active ? m.group_samples[g] : 0;
  const bool active = group_active && lane < m.group_samples[g + 1] - s0;
  const int s = s0 + lane;
  const long long E = m.group_entries;
  Vec3T<R> ps{0, 0, 0};
  R w[kGroupLanes];
  Vec3T<R> gr[kGroupLanes];
  const auto load_entry = [&](int k, R& wk, Vec3T<R>& gk) {
    const long long e = group_data_index(b, k, t);
    wk = m.group_data[e];
    gk = Vec3T<R>{m.group_data[E + e], m.group_data[2 * E + e], m.group_data[3 * E + e]};
  };
  Mat3T<R> F = zero3<R>();
  MaterialCacheT<R> cache{};
  const Material* mat = nullptr;
  if (active) {
    ps = Vec3T<R>{sample_value(f.sample_state, m.samples, 0, s), sample_value(f.sample_state, m.samples, 1, s),
                  sample_value(f.sample_state, m.samples, 2, s)};
#pragma unroll
    for (int k = 0; k < kGroupLanes; ++k)
      if (k < n) load_entry(k, w[k], gr[k]);
    mat = &m.materials[m.sample_materials[s]];
    ell_sample_material(m, f.sample_state, s, *mat, F, cache);
  }
  if (frame >= 0) group_frame_record(lever, di, rec + lane * kGroupRecord);
  __syncwarp();
  Mat3T<R> dF = zero3<R>(), dP = zero3<R>();  // dP: v dP
  if (active) {
#pragma unroll
    for (int k = 0; k < kGroupLanes; ++k)
      if (k < n) group_pair_dF(rec + k * kGroupRecord, ps, w[k], gr[k], dF);
    dP = sample_value(f.sample_state, m.samples, 3, s) * pk1_differential(*mat, F, cache, dF);
  }
  const int stride = m.slot_pair_offsets[m.block_slots[b + 1]] - m.slot_pair_offsets[m.block_slots[b]];
  const bool up4 = (lane & 4) != 0, up2 = (lane & 2) != 0, up1 = (lane & 1) != 0;
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
    const int k = 4 * half + (up4 ? 2 : 0) + (up2 ? 1 : 0), c0 = up1 ? 3 : 0;
    if (group_active && k < n) {
      const int pos = m.group_pos[kGroupLanes * static_cast<size_t>(g) + k];
#pragma unroll
      for (int c = 0; c < 3; ++c) outs[(c0 + c) * stride + pos] = three[c];
    }
  }
  __syncthreads();
  warp_slot_sums(m, outs, stride, b, slot_lanes, slot_partials);
}

}  // namespace fascia::gpu
