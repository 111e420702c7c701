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
// (frame_sample.hpp: [dr]x a = Q_i (p_s - x̄_i)), in 27 multiply-adds instead of 54.
// The outputs are the coalesced pass's v B_p^T dP = v [dP g, axial(M dP^T)] (eq. 21, 23, 25-26),
// summed per frame over the group's samples. With P_s = v dP (the sample's volume folded in),
// u_s = P_s g_s and c_s = p_s - x̄_i, and axial(a u^T) = a x u (frame_sample.hpp), frame i's sum is
//   f_i = Σ_s u_s,   t_i = axial(R_i B_i^T),   B_i = Σ_s (u_s c_s^T + w_s P_s)          (eq. 21)
// so that R_i is applied once per frame, not once per pair: per pair 9 multiply-adds on the
// sample's thread (u_s) and 24 on the frame's (group_frame_add), instead of 48 and a
// reduce-scatter of 48 values across the group's threads. Thread `lane` then holds frame lane's
// 6 sums, which meet the block's other groups in shared memory, where the block's slot sums
// (warp_slot_sums) add them in slot-major order.
#pragma once

#include "elasticity_phases.hpp"
#include "group_layout.hpp"

namespace fascia::gpu {

// A group's frame record, 16-byte aligned halves: [Q_i (9), dx (3) m, x̄_i - origin (3) m, 0,
// R_i (9), 0, 0, 0]; the dF half reads its first 16 values per pair, the frame's own thread the
// 16 from x̄_i on once (group_record_lever); 4 vector loads each (float; 8 in double).
constexpr int kGroupRecord = 28;
constexpr int kGroupThreads = kGroupBlock * kGroupLanes;

// A group's region of shared memory (values of R), used twice. First its frames' records, frame k
// at k kGroupRecord. Then, over them once the group's threads have read them, the frame sums'
// inputs: per sample s its P_s (9) and p_s - origin (3) at s kGroupSampleStride, and per pair
// (s, k) [u_s (3), w_s] in 16-byte quads, quad h at kGroupLanes kGroupSampleStride +
// (h kGroupLanes + s) kGroupPairStride + k kGroupQuad (group_pair_at).
// The strides keep 16-byte accesses free of bank conflicts: a sample's thread stores its pairs of
// frame k at a stride of 36 words (4 banks apart over 8 threads), a frame's thread reads its pairs
// of sample s next to the group's other frames', and the 4 groups of a warp reading the same
// record lie 4 banks apart (region of 388 words in float, 804 in double).
template <class R>
constexpr int kGroupQuad = 16 / static_cast<int>(sizeof(R));  // values per 16 bytes
template <class R>
constexpr int kGroupSampleStride = sizeof(R) == sizeof(float) ? 12 : 14;
template <class R>
constexpr int kGroupPairStride = (kGroupLanes + 1) * kGroupQuad<R>;
template <class R>
constexpr int kGroupRegion =
    kGroupLanes * kGroupSampleStride<R> + (4 / kGroupQuad<R>)*kGroupLanes * kGroupPairStride<R> + kGroupQuad<R>;
static_assert(kGroupRegion<float> >= kGroupLanes * kGroupRecord && kGroupRegion<double> >= kGroupLanes * kGroupRecord,
              "a group's region holds its records");
// The kernel's shared memory (values of R): the block's group regions, then its outputs [6][pairs].
template <class R>
constexpr int kGroupSharedValues = kGroupBlock * kGroupRegion<R> + 6 * kGroupThreads;

// Offset in a group's region of quad h of pair (sample s, frame k).
template <class R>
FASCIA_HD int group_pair_at(int s, int k, int h) {
  return kGroupLanes * kGroupSampleStride<R> + (h * kGroupLanes + s) * kGroupPairStride<R> + k * kGroupQuad<R>;
}

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

// Frame i's x̄_i - origin and R_i from its group record.
template <class R>
FASCIA_HD void group_record_lever(const R* rec, Vec3T<R>& xbar, Mat3T<R>& Ri) {
  R v[16];
  load_shared<16>(rec + 12, v);
  xbar = Vec3T<R>{v[0], v[1], v[2]};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Ri.m[r][c] = v[4 + 3 * r + c];
}

// Adds sample s's terms to its frame's sums f and B (header): u = P_s g and w of the pair, P_s =
// v dP, ps = p_s - origin, xbar = x̄_i - origin; 24 multiply-adds.
template <class R>
FASCIA_HD void group_frame_add(const Vec3T<R>& u, R w, const Mat3T<R>& P, const Vec3T<R>& ps, const Vec3T<R>& xbar,
                               Vec3T<R>& f, Mat3T<R>& B) {
  const Vec3T<R> c = ps - xbar;
  const R uv[3] = {u.x, u.y, u.z}, cv[3] = {c.x, c.y, c.z};
  f += u;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) B.m[r][k] += uv[r] * cv[k] + w * P.m[r][k];
}

// Frame i's outputs [f_i, axial(R_i B_i^T)] (6 values) from its sums.
template <class R>
FASCIA_HD void group_frame_output(const Mat3T<R>& Ri, const Vec3T<R>& f, const Mat3T<R>& B, R* out) {
  store_pair_values(f, axial_times_transpose(Ri, B), out);
}

// w and g of thread `lane`'s pair with frame k of a mapped group: w = w_c(lane, k), g = A r_c(lane, k)
// (group_classes.hpp), from its class's table `pairs` (class_pairs of the class).
template <class R>
FASCIA_HD void group_class_entry(const R* pairs, const Mat3T<R>& A, int lane, int k, R& w, Vec3T<R>& g) {
  R ref[4];
  load_aligned<4>(pairs + 4 * (kGroupLanes * lane + k), ref);
  w = ref[0];
  g = A * Vec3T<R>{ref[1], ref[2], ref[3]};
}

// Index of entry (block b, frame k, block thread t) of group_data.
FASCIA_HD long long group_data_index(int b, int k, int t) {
  return (static_cast<long long>(b) * kGroupLanes + k) * kGroupThreads + t;
}

// Where component c (w, g_x, g_y, g_z) of entry e of E lies in group_data: in float each entry's 4
// values together (one 16-byte load per pair), in double in component rows (two 16-byte loads
// per entry would not be coalesced better, and measured slower with the entries together).
template <class R>
FASCIA_HD long long group_data_offset(long long e, int c, long long E) {
  if constexpr (sizeof(R) == sizeof(float)) return 4 * e + c;
  return c * E + e;
}

}  // namespace fascia::gpu
