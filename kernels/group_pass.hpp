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
// outputs are the coalesced pass's v B_p^T dP = v [dP g, axial(M dP^T)] (eq. 21, 23, 25-26),
// with v folded into dP once per sample (group_pair_output).
// The group's outputs of one frame are summed across its threads (group_lane_sum's order), so
// that one value per (group, frame) entry, not per pair, meets the block's other groups in shared
// memory, where the block's slot sums (warp_slot_sums) add them in slot-major order.
#pragma once

#include "elasticity_phases.hpp"
#include "group_layout.hpp"

namespace fascia::gpu {

// A group's frame record, 16-byte aligned halves: [Q_i (9), dx (3) m, x̄_i - origin (3) m, 0,
// R_i (9), 0, 0, 0]; the dF half reads its first 16 values, the output half the 16 from x̄_i on,
// 4 vector loads each (float; 8 in double).
constexpr int kGroupRecord = 28;
// The records of a block's groups in shared memory: group gl's frame k at (gl kGroupSlotStride +
// k) kGroupRecord. With a slot stride of 9 the threads of a warp that load the same 16 bytes of
// their 4 groups' frame k hit distinct banks, in float (record stride 28 words) and in double (56).
constexpr int kGroupSlotStride = kGroupLanes + 1;
constexpr int kGroupRecords = kGroupBlock * kGroupSlotStride * kGroupRecord;
constexpr int kGroupThreads = kGroupBlock * kGroupLanes;

// Frame record of a group from the frame's lever record (kLeverRecord values) and direction d (6).
template <class R>
FASCIA_HD void group_frame_record(const R* lever, const R* d, R* rec) {
  Mat3T<R> Ri;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Ri.m[r][c] = lever[3 * r + c];
  const Mat3T<R> Q = skew_times(Vec3T<R>{d[3], d[4], d[5]}, Ri);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) rec[3 * r + c] = Q.m[r][c];
  for (int k = 0; k < 3; ++k) rec[9 + k] = d[k];
  for (int k = 0; k < 3; ++k) rec[12 + k] = lever[9 + k];
  rec[15] = R(0);
  for (int k = 0; k < 9; ++k) rec[16 + k] = lever[k];
  for (int k = 25; k < kGroupRecord; ++k) rec[k] = R(0);
}

// Adds the pair's dF_p = (dx + Q (p_s - x̄)) g^T + w Q from its frame's group record.
template <class R>
FASCIA_HD void group_pair_dF(const R* rec, const Vec3T<R>& ps, R w, const Vec3T<R>& g, Mat3T<R>& dF) {
  R v[16];
  load_shared<16>(rec, v);
  Mat3T<R> Q;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Q.m[r][c] = v[3 * r + c];
  const Vec3T<R> u = Vec3T<R>{v[9], v[10], v[11]} + Q * (ps - Vec3T<R>{v[12], v[13], v[14]});
  dF += outer(u, g) + w * Q;
}

// The pair's B_p^T P = [P g, axial(M P^T)] (P = v dP, the sample's volume folded in) into out (6
// values), with M = a g^T + w R_i, a = R_i (p_s - x̄_i), from the group record, as
// [u, a x u + w axial(R_i P^T)], u = P g (frame_sample.hpp: axial(a u^T) = a x u): 48
// multiply-adds instead of forming M's 18.
template <class R>
FASCIA_HD void group_pair_output(const R* rec, const Vec3T<R>& ps, R w, const Vec3T<R>& g, const Mat3T<R>& P,
                                 R* out) {
  R v[16];
  load_shared<16>(rec + 12, v);
  Mat3T<R> Ri;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Ri.m[r][c] = v[4 + 3 * r + c];
  const Vec3T<R> a = Ri * (ps - Vec3T<R>{v[0], v[1], v[2]});
  const Vec3T<R> u = P * g;
  store_pair_values(u, cross(a, u) + w * axial_times_transpose(Ri, P), out);
}

// The sum of one output value over a group's kGroupLanes threads (o: thread l's value, 0 for a
// thread without a sample), in the order of the kernel's reduce-scatter across the threads
// (exchanges at distance 4, 2, 1; additions commute, so every thread that holds it has these bits).
template <class R>
FASCIA_HD R group_lane_sum(const R* o) {
  static_assert(kGroupLanes == 8, "the reduce-scatter is written for 8 threads per group");
  return ((o[0] + o[4]) + (o[2] + o[6])) + ((o[1] + o[5]) + (o[3] + o[7]));
}

// Index of entry (block b, frame k, block thread t) of group_data.
FASCIA_HD long long group_data_index(int b, int k, int t) {
  return (static_cast<long long>(b) * kGroupLanes + k) * kGroupThreads + t;
}

// Where component c (w, g_x, g_y, g_z) of entry e of E lies in group_data: in float each entry's 4
// values together (one 16-byte load per pair), in double in component rows (two 16-byte loads
// per entry would not be coalesced better).
template <class R>
FASCIA_HD long long group_data_offset(long long e, int c, long long E) {
  if constexpr (sizeof(R) == sizeof(float)) return 4 * e + c;
  return c * E + e;
}

}  // namespace fascia::gpu
