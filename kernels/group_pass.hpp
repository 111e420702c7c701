// Grouped tangent pass: the per-thread bodies that the kernel (group_kernels.cuh) and the host
// emulation share. Layout: group_layout.hpp.
//
// A block runs kGroupBlock groups of kGroupLanes threads; thread `lane` of a group takes its
// sample lane and, while the group's records are formed, its frame lane. Per group and frame i,
// once, from the lever record [R_i, x̄_i - origin] and the direction d_i = [dx, dr]:
//   Q_i = [dr]x R_i,
// so that each pair (w, g) of a sample at p_s (minus origin) needs
//   dF_p = (dx + Q_i (p_s - x̄_i)) g^T + w Q_i                                   (eq. 11)
// the same dF_p as dx g^T + [dr]x M with the lever M = a g^T + w R_i, a = R_i (p_s - x̄_i)
// (frame_sample.hpp: [dr]x a = Q_i (p_s - x̄_i)), in 27 multiply-adds instead of 54. The
// outputs are the coalesced pass's v B_p^T dP = v [dP g, axial(M dP^T)] (eq. 21, 23, 25-26).
// The group's outputs of one frame are summed across its threads (group_lane_sum's order), so
// that one value per (group, frame) entry, not per pair, meets the block's other groups in shared
// memory, where the block's slot sums (warp_slot_sums) add them in slot-major order.
#pragma once

#include "elasticity_phases.hpp"
#include "group_layout.hpp"

namespace fascia::gpu {

constexpr int kGroupRecord = 24;  // [Q_i (9), dx (3) m, x̄_i - origin (3) m, R_i (9)]
// The records of a block's groups in shared memory, component-major: value c of block-local group
// gl's frame k at c kGroupRecordStride + gl kGroupSlotStride + k. With a slot stride of 9 the
// threads of a warp that read the same value of their 4 groups' frame k hit distinct banks, in
// float and in double.
constexpr int kGroupSlotStride = kGroupLanes + 1;
constexpr int kGroupRecordStride = kGroupBlock * kGroupSlotStride;
constexpr int kGroupThreads = kGroupBlock * kGroupLanes;

// Frame record of a group (stride between its values) from the frame's lever record (kLeverRecord
// values) and direction d (6 values).
template <class R>
FASCIA_HD void group_frame_record(const R* lever, const R* d, R* rec, int stride) {
  Mat3T<R> Ri;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Ri.m[r][c] = lever[3 * r + c];
  const Mat3T<R> Q = skew_times(Vec3T<R>{d[3], d[4], d[5]}, Ri);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) rec[(3 * r + c) * stride] = Q.m[r][c];
  for (int k = 0; k < 3; ++k) rec[(9 + k) * stride] = d[k];
  for (int k = 0; k < 3; ++k) rec[(12 + k) * stride] = lever[9 + k];
  for (int k = 0; k < 9; ++k) rec[(15 + k) * stride] = lever[k];
}

// Adds the pair's dF_p = (dx + Q (p_s - x̄)) g^T + w Q from its frame's group record.
template <class R>
FASCIA_HD void group_pair_dF(const R* rec, int stride, const Vec3T<R>& ps, R w, const Vec3T<R>& g, Mat3T<R>& dF) {
  Mat3T<R> Q;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Q.m[r][c] = rec[(3 * r + c) * stride];
  const Vec3T<R> dx{rec[9 * stride], rec[10 * stride], rec[11 * stride]};
  const Vec3T<R> xbar{rec[12 * stride], rec[13 * stride], rec[14 * stride]};
  const Vec3T<R> u = dx + Q * (ps - xbar);
  dF += outer(u, g) + w * Q;
}

// The pair's v B_p^T dP into out (6 values), with the lever formed from the group record.
template <class R>
FASCIA_HD void group_pair_output(const R* rec, int stride, const Vec3T<R>& ps, R w, const Vec3T<R>& g,
                                 const Mat3T<R>& dP, R v, R* out) {
  Mat3T<R> Ri;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Ri.m[r][c] = rec[(15 + 3 * r + c) * stride];
  const Vec3T<R> xbar{rec[12 * stride], rec[13 * stride], rec[14 * stride]};
  const Vec3T<R> a = Ri * (ps - xbar);
  R o[6];
  pair_lever_virtual_work(dP, g, pair_lever(a, g, w, Ri), o);
  for (int k = 0; k < 6; ++k) out[k] = v * o[k];
}

// The sum of one output value over a group's kGroupLanes threads (o: thread l's value, 0 for a
// thread without a sample), in the order of the kernel's reduce-scatter across the threads
// (exchanges at distance 4, 2, 1; additions commute, so every thread that holds it has these bits).
template <class R>
FASCIA_HD R group_lane_sum(const R* o) {
  static_assert(kGroupLanes == 8, "the reduce-scatter is written for 8 threads per group");
  return ((o[0] + o[4]) + (o[2] + o[6])) + ((o[1] + o[5]) + (o[3] + o[7]));
}

// Index of component c of entry (block b, frame k, block thread t) in group_data's rows.
FASCIA_HD long long group_data_index(int b, int k, int t) {
  return (static_cast<long long>(b) * kGroupLanes + k) * kGroupThreads + t;
}

}  // namespace fascia::gpu
