// Host-side preparation of the device layout of a model (no CUDA needed):
//  - samples reordered along a Morton (Z-order) curve of their rest positions, so that the
//    samples of one thread block touch few, nearby frames and neighbouring threads read nearby
//    memory (the device results are per frame and do not depend on the sample order beyond
//    rounding);
//  - the block tables of the fused design (elasticity_phases.hpp): consecutive samples grouped
//    into blocks, each block's distinct frames ("slots") with the block-local pairs that touch
//    them, and per frame the slots that hold its partial sums. Every list is in increasing order,
//    which fixes the summation order and makes the device results bitwise reproducible.
#pragma once

#include "model/model.hpp"

#include <vector>

namespace fascia::gpu {

// The permutation of samples along a Morton curve: new sample k is old sample order[k].
std::vector<int> spatial_sample_order(const Model& model);

// A copy of the model with samples (and their neighbour pairs) permuted; frames, materials,
// masses and constraints unchanged; the reverse table rebuilt.
Model reorder_samples(const Model& model, const std::vector<int>& order);

// True when every rest offset l_p equals p_s - x_i up to rel_tol times the model's extent: the
// fused design rebuilds l_p from rest positions (eq. 2 with rest orientation I).
bool offsets_are_rest_differences(const Model& model, double rel_tol = 1e-12);

struct BlockLayout {
  int max_block_pairs = 0;
  std::vector<int> block_samples;       // [B+1]
  std::vector<int> block_slots;         // [B+1]
  std::vector<int> slot_frames;         // [Q]
  std::vector<int> slot_pair_offsets;   // [Q+1]
  std::vector<int> slot_pairs;          // [P] pair index minus the block's first pair
  std::vector<int> frame_slot_offsets;  // [N+1]
  std::vector<int> frame_slots;         // [Q]
  int block_count() const { return static_cast<int>(block_samples.size()) - 1; }
  int slot_count() const { return static_cast<int>(slot_frames.size()); }
};

// Blocks of at most max_samples consecutive samples and at most max_pairs pairs (a sample with
// more pairs than that gets a block of its own: there is no cap on neighbours).
BlockLayout build_block_layout(const Model& model, int max_samples, int max_pairs);

}  // namespace fascia::gpu
