// Host layout of the matrix-free tangent product K d for SIMD units (CPU only; the CUDA backend
// has its own layout in kernels/sample_layout.hpp).
//
// Samples are taken kLanes at a time in blocks of nearby samples with about as many neighbours
// (the last block padded with empty lanes of zero volume). Slot k of a block holds the k-th
// neighbour pair of each of its samples; a block has as many slots as its sample with the most
// neighbours, and a sample with fewer neighbours has empty slots (zero lever and gradient). Every
// per-slot and per-block array is structure-of-arrays across the lanes ([...][kLanes]), so the
// per-pair math of frame_sample.hpp runs on kLanes samples at once and the product streams each
// array once.
//
// Per state (Elasticity::prepare) a slot holds the pair's lever M = a g^T + w R and its weight
// gradient g; a block holds, per lane, F, v S, v lambda, v mu (StVK) or F^-T, v c, v lambda,
// v mu (neo-Hookean, c = mu - lambda ln J). The product is then
//   dF_s = sum_p dx_i g_p^T + [dr_i]x M_p               (eq. 11)
//   v dP = dF (v S) + F (v lambda tr(dE) I + 2 v mu dE),  dE = sym(F^T dF)   (eq. 22-26, StVK)
//   v dP = v mu dF + v c F^-T dF^T F^-T + v lambda (F^-T : dF) F^-T         (neo-Hookean)
//   out_p = [v dP g_p, axial(M_p (v dP)^T)]           (eq. 21, 23, 25-26)
// written to a share buffer (one cache line per pair), then summed per frame in a fixed order (no
// atomics, the result does not depend on the number of threads). Blocks of mixed laws or of
// another law take v dP from the generic pk1_differential, lane by lane.
#pragma once

#include "core/small_math.hpp"
#include "material/material.hpp"
#include "model/model.hpp"

#include <cstdint>
#include <vector>

namespace fascia {

constexpr int kLanes = 4;
// Values per slot lane: the lever M (9, row-major) then the weight gradient g (3).
constexpr int kSlotValues = 12;

class SampleLanes {
 public:
  // Builds the layout (block slots, slot frames, weight gradients, reverse positions) for model.
  explicit SampleLanes(const Model& model);

  // Per-state data of one sample s: F, the material cache (S for StVK, F^-T and c for
  // neo-Hookean) and the volume.
  void set_sample(int s, const Material& material, double volume, const Mat3& F, const MaterialCache& cache);
  // Where the levers of sample s go: set_lever(levers_of(s), k, M) stores its k-th pair's lever.
  double* levers_of(int s) {
    const int lane = m_sample_lanes[s];
    return &m_slot_data[static_cast<size_t>(kSlotValues) * kLanes * m_block_slots[lane / kLanes] + lane % kLanes];
  }
  static void set_lever(double* levers, int k, const Mat3& lever) {
    double* p = levers + static_cast<size_t>(kSlotValues) * kLanes * k;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) p[(3 * r + c) * kLanes] = lever.m[r][c];
  }

  // The per-pair shares of K d for blocks [first, last).
  // d: [N][6]. F, cache: Elasticity's per-sample arrays, read only for blocks of mixed or other laws.
  void pair_products(const double* d, const Model& model, const double* F, const MaterialCache* cache, int first,
                     int last);
  // out_i = sum of frame i's pair shares + [t_i dx_i, (G_i + Q_i) dr_i] for frames [first, last),
  // with G: [N][9] (Elasticity's rotational geometric blocks) and extra (may be null): [N][10],
  // t_i then Q_i row-major.
  void gather(const double* d, const double* G, const double* extra, double* out, int first, int last) const;

  int block_count() const { return static_cast<int>(m_block_slots.size()) - 1; }

 private:
  std::vector<int> m_lane_samples;      // [B][kLanes] the sample in each lane, -1: empty
  std::vector<int> m_sample_lanes;      // [S] the lane position (kLanes b + l) of each sample
  std::vector<int> m_block_slots;       // [B+1] slot range of each block
  std::vector<std::uint8_t> m_laws;     // [B] the law of the block's lanes (sample_lanes.cpp)
  std::vector<int> m_slot_frames;       // [slots][kLanes] 6 i, i the frame of each slot lane
  std::vector<double> m_slot_data;      // [slots][kSlotValues][kLanes] lever M (row-major) then g
  std::vector<double> m_block_data;     // [B][17][kLanes] F, v S (xx yy zz yz xz xy) or F^-T, v c; v lambda, v mu
  std::vector<double> m_slot_out;       // [slots][kLanes][8] per-pair shares of K d (6 values, 2 zeros)
  std::vector<int> m_frame_offsets;     // [N+1]
  std::vector<int> m_frame_entries;     // [P] index of the share's first value in m_slot_out
};

}  // namespace fascia
