// The grouped tangent pass's kernel (group_pass.hpp): one block of kGroupBlock groups of
// kGroupLanes threads, the view `m` over the blocks of groups (ModelView, grouped fields).
#pragma once

#include "elasticity_kernels.cuh"
#include "group_pass.hpp"

namespace fascia::gpu {

// Whether the kernel runs its blocks of groups as tiles of a resident grid and copies each
// thread's data for its next tile into shared memory (group_prefetch) while it computes the
// current one (float, not mapped): the pairs' w and g and the sample's position, volume and H,
// 0.75 of the pass's DRAM bytes, then arrive while the SM computes instead of at each tile's start.
// Double, whose staged data would leave room for fewer blocks per SM, and the mapped pass, which
// reads little, load them at each tile's start.
template <class R, bool Mapped>
constexpr bool group_prefetches() {
#ifdef FASCIA_GROUP_NO_PREFETCH
  return false;
#else
  return sizeof(R) == sizeof(float) && !Mapped;
#endif
}

#ifndef FASCIA_GROUP_STAGED_STATE
#define FASCIA_GROUP_STAGED_STATE 13
#endif
// The state components staged per sample: position (3), volume and H (9), which every law reads.
constexpr int kGroupStagedState = FASCIA_GROUP_STAGED_STATE;

// The stage of the prefetching kernel (values of R): thread t's pair with frame k at
// 4 (k kGroupThreads + t) ([w, g]), its sample's state component c at kGroupEntryStage +
// c kGroupThreads + t; its frame's lever record (3 quads), direction and previous direction (3
// pairs each) at kGroupFrameStage, quad or pair q at q kGroupThreads + t; its sample's material
// at kGroupMaterialStage + t. Each copy lies next to the block's other threads'.
constexpr int kGroupEntryStage = 4 * kGroupLanes * kGroupThreads;
constexpr int kGroupFrameStage = kGroupEntryStage + kGroupStagedState * kGroupThreads;
constexpr int kGroupMaterialStage = kGroupFrameStage + (kLeverRecord + 12) * kGroupThreads;
template <class R, bool Mapped>
constexpr int group_stage_values() {
  return group_prefetches<R, Mapped>() ? kGroupMaterialStage + kGroupThreads : 0;
}

// The kernel's dynamic shared memory in bytes: kGroupSharedValues, then the stage.
template <class R, bool Mapped>
constexpr size_t group_shared_bytes() {
  return (kGroupSharedValues<R> + group_stage_values<R, Mapped>()) * sizeof(R);
}

#ifndef FASCIA_GROUP_FLOAT_BLOCKS
#define FASCIA_GROUP_FLOAT_BLOCKS 3
#endif
// Blocks per multiprocessor the kernel is compiled for (registers within 65,536 / (128 blocks));
// float keeps each sample's w and g in registers between the two halves, double reads them again.
template <class R, bool Mapped>
constexpr int group_blocks_per_sm() {
  if (sizeof(R) != sizeof(float)) return 3;
  return group_prefetches<R, Mapped>() ? FASCIA_GROUP_FLOAT_BLOCKS : 5;
}

// Asynchronous copies from global to shared memory (cp.async; 16 bytes through L2 only, 4 through
// L1), then the commit of the thread's copies so far as one group, and the wait for all of them:
// each thread reads only what it copied itself.
__device__ inline void copy_async16(void* shared, const void* global) {
  const unsigned s = static_cast<unsigned>(__cvta_generic_to_shared(shared));
  asm volatile("cp.async.cg.shared.global [%0], [%1], 16;\n" ::"r"(s), "l"(global) : "memory");
}
__device__ inline void copy_async8(void* shared, const void* global) {
  const unsigned s = static_cast<unsigned>(__cvta_generic_to_shared(shared));
  asm volatile("cp.async.ca.shared.global [%0], [%1], 8;\n" ::"r"(s), "l"(global) : "memory");
}
__device__ inline void copy_async4(void* shared, const void* global) {
  const unsigned s = static_cast<unsigned>(__cvta_generic_to_shared(shared));
  asm volatile("cp.async.ca.shared.global [%0], [%1], 4;\n" ::"r"(s), "l"(global) : "memory");
}
__device__ inline void copy_async_commit() { asm volatile("cp.async.commit_group;\n" ::: "memory"); }
__device__ inline void copy_async_wait_all() { asm volatile("cp.async.wait_group 0;\n" ::: "memory"); }

// Thread t's copies of tile b's staged data (group_stage_values): its pairs' w and g; where it
// has a sample (its group g < m.group_count with samples [s0, s1)), the sample's state and
// material; where it has a frame (frame >= 0), the frame's lever record, d and p_old (if given).
template <class R>
__device__ void group_prefetch(const ModelView<R>& m, const FrameView<R>& f, const R* d, const R* p_old, int b, int t,
                               int s0, int s1, int frame, R* stage) {
  const long long E = m.group_entries;
#pragma unroll
  for (int k = 0; k < kGroupLanes; ++k)
    copy_async16(stage + 4 * (k * kGroupThreads + t), m.group_data + group_data_offset<R>(group_data_index(b, k, t), 0, E));
  const int s = s0 + t % kGroupLanes;
  if (s < s1) {
#pragma unroll
    for (int c = 0; c < kGroupStagedState; ++c)
      copy_async4(stage + kGroupEntryStage + c * kGroupThreads + t,
                  f.sample_state + static_cast<size_t>(c) * static_cast<size_t>(m.samples) + static_cast<size_t>(s));
    copy_async4(stage + kGroupMaterialStage + t, m.sample_materials + s);
  }
  if (frame >= 0) {
    R* fs = stage + kGroupFrameStage;
    const size_t i = static_cast<size_t>(frame);
#pragma unroll
    for (int q = 0; q < 3; ++q) copy_async16(fs + 4 * (q * kGroupThreads + t), f.levers + kLeverRecord * i + 4 * q);
    fs += 4 * 3 * kGroupThreads;
#pragma unroll
    for (int q = 0; q < 3; ++q) copy_async8(fs + 2 * (q * kGroupThreads + t), d + 6 * i + 2 * q);
    fs += 2 * 3 * kGroupThreads;
    if (p_old) {
#pragma unroll
      for (int q = 0; q < 3; ++q) copy_async8(fs + 2 * (q * kGroupThreads + t), p_old + 6 * i + 2 * q);
    }
  }
  copy_async_commit();
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

// Tangent sample pass, grouped (ModelView's grouped fields; `d`, `p_old`, scalars as
// k_ell_tangent): per group its frames' records into its shared region, per thread its sample's
// dF, P = v dP and u = P g of each pair; then, over the records, each sample's P and its pairs'
// u and w, from which thread `lane` sums its frame's outputs over the group's samples in sample
// order (group_pass.hpp: group_frame_add, group_frame_output); each (group, frame) entry's sums
// into shared memory at its slot-major position, then `slot_lanes` lanes per slot sum the block's
// slots (group_slot_sums). Block b of the grid runs tiles (blocks of groups) b, b + gridDim.x, ...;
// prefetching (group_prefetches), each thread copies its data for its next tile once it has read
// the current one's. Mapped: w and g from the group's class and map (group_classes.hpp) instead of
// group_data. Dynamic shared memory: group_shared_bytes.
template <class R, bool Mapped>
__global__ void __launch_bounds__(kGroupThreads, group_blocks_per_sm<R, Mapped>())
    k_group_tangent(ModelView<R> m, FrameView<R> f, const R* d, const R* p_old, R* slot_partials, const Scalars* sc,
                    int slot_lanes) {
  constexpr bool kPrefetch = group_prefetches<R, Mapped>();
  constexpr bool kKeepEntries = sizeof(R) == sizeof(float);
  extern __shared__ __align__(16) unsigned char group_shared[];
  R* regions = reinterpret_cast<R*>(group_shared);
  R* outs = regions + kGroupBlock * kGroupRegion<R>;
  R* stage = outs + 6 * kGroupThreads;
  const int t = static_cast<int>(threadIdx.x);
  const int gl = t / kGroupLanes, lane = t % kGroupLanes;
  if (finished(sc)) return;
  const double beta = p_old ? sc->beta : 0.0;
  const long long E = m.group_entries;
  R* region = regions + gl * kGroupRegion<R>;  // the group's frame k's record at region + k kGroupRecord
  const int tiles = m.blocks;
  const int first = static_cast<int>(blockIdx.x);
  // Frame `lane` of the thread's group in tile b, -1 past its frames or the groups.
  const auto group_frame = [&](int b) {
    const int g = b * kGroupBlock + gl;
    return b < tiles && g < m.group_count ? m.group_frames[kGroupLanes * static_cast<size_t>(g) + lane] : -1;
  };
  if constexpr (kPrefetch) {
    if (first < tiles) {
      const int g = first * kGroupBlock + gl;
      const bool ga = g < m.group_count;
      group_prefetch(m, f, d, p_old, first, t, ga ? m.group_samples[g] : 0, ga ? m.group_samples[g + 1] : 0,
                     group_frame(first), stage);
    }
  }
  // Tile b (its blocks of groups) of the grid, with the thread's `frame` (group_frame), then,
  // prefetching, the copies of the next tile's data.
  const auto tile = [&](int b, int frame, int next_frame) {
    const int g = b * kGroupBlock + gl;  // blocks of kGroupBlock consecutive groups (group_layout.hpp)
    const bool group_active = g < m.group_count;
    // The loads that depend on nothing else, issued together: the group's frame `lane`, first
    // sample and the slot-major position of its entry (g, lane), the block's slot range, and the
    // next tile's samples of the thread's group.
    const size_t entry = kGroupLanes * static_cast<size_t>(g);
    const int s0 = group_active ? m.group_samples[g] : 0, s1 = group_active ? m.group_samples[g + 1] : 0;
    const int next = b + static_cast<int>(gridDim.x), gn = next * kGroupBlock + gl;
    int next_s0 = 0, next_s1 = 0;
    if (kPrefetch && next < tiles && gn < m.group_count) {
      next_s0 = m.group_samples[gn];
      next_s1 = m.group_samples[gn + 1];
    }
    // Float also loads here what the outputs and the slot sums need (position, the block's
    // slots); double, where registers are short, loads them there.
    constexpr bool kPreload = sizeof(R) == sizeof(float);
    BlockSlots bs;
    if constexpr (kPreload) bs = block_slot_range(m, b);
    int pos = 0;
    if (kPreload && frame >= 0) pos = m.group_pos[entry + lane];
    // Then every global load of the dF half and the material, so that their latencies overlap:
    // thread `lane` gathers its group's frame `lane` (lever record, direction) and reads its
    // group's sample `lane` (position, w and g of its pairs, H and the material cache); and the
    // block's slot-sum bounds (group_slot_sums).
    R lever[kLeverRecord], di[6];
    if constexpr (kPrefetch) copy_async_wait_all();
    if (frame >= 0) {
      R po[6] = {0, 0, 0, 0, 0, 0};
      if constexpr (kPrefetch) {
        const R* fs = stage + kGroupFrameStage;
#pragma unroll
        for (int q = 0; q < 3; ++q) load_shared<4>(fs + 4 * (q * kGroupThreads + t), lever + 4 * q);
        fs += 4 * 3 * kGroupThreads;
#pragma unroll
        for (int q = 0; q < 3; ++q) load_shared<2>(fs + 2 * (q * kGroupThreads + t), di + 2 * q);
        fs += 2 * 3 * kGroupThreads;
        if (p_old) {
#pragma unroll
          for (int q = 0; q < 3; ++q) load_shared<2>(fs + 2 * (q * kGroupThreads + t), po + 2 * q);
        }
      } else {
        load_aligned<kLeverRecord>(f.levers + kLeverRecord * static_cast<size_t>(frame), lever);
        load_six(d, frame, di);
        if (p_old) load_six(p_old, frame, po);
      }
      if (p_old) {
#pragma unroll
        for (int k = 0; k < 6; ++k) di[k] = direction_value(di[k], po[k], beta);
      }
    }
    // The group's frame count: its threads' bits of the warp's ballot (frames come first).
    const unsigned present = __ballot_sync(0xffffffffu, frame >= 0);
    const int n = __popc((present >> (t & 31 & ~(kGroupLanes - 1))) & ((1u << kGroupLanes) - 1));
    const int ns = s1 - s0;
    const bool active = group_active && lane < ns;
    const int s = s0 + lane;
    SlotBounds bounds;  // this thread's slot of the first round of the slot sums
    if constexpr (kPreload) bounds = slot_bounds(m, bs.q0 + t / slot_lanes, bs.q1, bs.base);
    Vec3T<R> ps{0, 0, 0};
    R w[kGroupLanes];
    Vec3T<R> gr[kGroupLanes];
    // Mapped: the group's map A_g and its class's table (group_class_entry).
    Mat3T<R> A = zero3<R>();
    const R* class_pairs = nullptr;
    if constexpr (Mapped) {
      if (group_active) {
        const size_t G = static_cast<size_t>(m.group_count);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) A.m[r][c] = m.group_maps[(3 * r + c) * G + g];
        class_pairs = m.group_class_pairs + 4 * kGroupLanes * kGroupLanes * static_cast<size_t>(m.group_class[g]);
      }
    }
    const auto load_entry = [&](int k, R& wk, Vec3T<R>& gk) {
      if constexpr (Mapped) {
        group_class_entry(class_pairs, A, lane, k, wk, gk);
      } else {
        R v[4];
        if constexpr (kPrefetch) {
          load_shared<4>(stage + 4 * (k * kGroupThreads + t), v);
        } else if constexpr (sizeof(R) == sizeof(float)) {
          load_aligned<4>(m.group_data + group_data_offset<R>(group_data_index(b, k, t), 0, E), v);
        } else {
          const long long e = group_data_index(b, k, t);
          for (int c = 0; c < 4; ++c) v[c] = m.group_data[c * E + e];
        }
        wk = v[0];
        gk = Vec3T<R>{v[1], v[2], v[3]};
      }
    };
    // State component c of the thread's sample: staged, or read from the state.
    const auto state_value = [&](int c) {
      if constexpr (kPrefetch) {
        if (c < kGroupStagedState) return stage[kGroupEntryStage + c * kGroupThreads + t];
      }
      return sample_value(f.sample_state, m.samples, c, s);
    };
    Mat3T<R> F = zero3<R>();
    MaterialCacheT<R> cache{};
    const Material* mat = nullptr;
    R volume = 0;
    if (active) {
      ps = Vec3T<R>{state_value(0), state_value(1), state_value(2)};
#pragma unroll
      for (int k = 0; k < kGroupLanes; ++k)
        if (k < n) load_entry(k, w[k], gr[k]);
      if constexpr (kPrefetch)
        mat = &m.materials[reinterpret_cast<const int*>(stage + kGroupMaterialStage)[t]];
      else
        mat = &m.materials[m.sample_materials[s]];
      Mat3T<R> H;
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) H.m[r][k] = state_value(4 + 3 * r + k);
      volume = state_value(3);
      sample_material_from_H(H, *mat, f.sample_state, m.samples, s, F, cache);
    }
    if (frame >= 0) group_frame_record(lever, di, region + lane * kGroupRecord);
    __syncwarp();
    Mat3T<R> dF = zero3<R>(), P = zero3<R>();  // P = v dP
    if (active) {
#pragma unroll
      for (int k = 0; k < kGroupLanes; ++k)
        if (k < n) group_pair_dF(region + k * kGroupRecord, ps, w[k], gr[k], dF);
      P = volume * pk1_differential(*mat, F, cache, dF);
    }
    // The stage read (its values used), the next tile's copies.
    if constexpr (kPrefetch) {
      if (next < tiles) group_prefetch(m, f, d, p_old, next, t, next_s0, next_s1, next_frame, stage);
    }
    // Frame lane's lever from its record, then the region holds the frame sums' inputs once every
    // thread of the warp has read the records.
    Vec3T<R> xbar{0, 0, 0};
    Mat3T<R> Ri = zero3<R>();
    if (frame >= 0) group_record_lever(region + lane * kGroupRecord, xbar, Ri);
    __syncwarp();
    if (active) {
      const R sample[12] = {P.m[0][0], P.m[0][1], P.m[0][2], P.m[1][0], P.m[1][1], P.m[1][2],
                            P.m[2][0], P.m[2][1], P.m[2][2], ps.x,      ps.y,      ps.z};
      store_shared<12>(sample, region + lane * kGroupSampleStride<R>);
#pragma unroll
      for (int k = 0; k < kGroupLanes; ++k) {
        if (k < n) {
          R wk = 0;
          Vec3T<R> gk{0, 0, 0};
          if constexpr (kKeepEntries) {
            wk = w[k];
            gk = gr[k];
          } else {
            load_entry(k, wk, gk);
          }
          const Vec3T<R> u = P * gk;
          const R pair[4] = {u.x, u.y, u.z, wk};
#pragma unroll
          for (int h = 0; h < 4 / kGroupQuad<R>; ++h)
            store_shared<kGroupQuad<R>>(pair + h * kGroupQuad<R>, region + group_pair_at<R>(lane, k, h));
        }
      }
    }
    __syncwarp();
    if constexpr (!kPreload) bs = block_slot_range(m, b);
    const int stride = bs.stride;
    if (frame >= 0) {
      Vec3T<R> fsum{0, 0, 0};
      Mat3T<R> B = zero3<R>();
#pragma unroll
      for (int j = 0; j < kGroupLanes; ++j) {
        if (j < ns) {
          R sample[12], pair[4];
          load_shared<12>(region + j * kGroupSampleStride<R>, sample);
#pragma unroll
          for (int h = 0; h < 4 / kGroupQuad<R>; ++h)
            load_shared<kGroupQuad<R>>(region + group_pair_at<R>(j, lane, h), pair + h * kGroupQuad<R>);
          Mat3T<R> Pj;
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) Pj.m[r][c] = sample[3 * r + c];
          group_frame_add(Vec3T<R>{pair[0], pair[1], pair[2]}, pair[3], Pj,
                          Vec3T<R>{sample[9], sample[10], sample[11]}, xbar, fsum, B);
        }
      }
      R o[6];
      group_frame_output(Ri, fsum, B, o);
      const int at = kPreload ? pos : m.group_pos[entry + lane];
#pragma unroll
      for (int c = 0; c < 6; ++c) outs[c * stride + at] = o[c];
    }
    __syncthreads();
    group_slot_sums<kPreload>(m, outs, stride, bounds, bs.q0, bs.q1, bs.base, slot_lanes, slot_partials);
  };
  if constexpr (kPrefetch) {
    // Each tile's frames are read during the tile before, so that its gathers wait on one load.
    int frame = group_frame(first);
    for (int b = first; b < tiles; b += static_cast<int>(gridDim.x)) {
      const int next_frame = group_frame(b + static_cast<int>(gridDim.x));
      tile(b, frame, next_frame);
      frame = next_frame;
      __syncthreads();  // the outputs read before the next tile's are stored
    }
  } else if (first < tiles) {
    tile(first, group_frame(first), -1);
  }
}

}  // namespace fascia::gpu
