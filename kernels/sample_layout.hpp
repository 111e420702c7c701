// Host-side preparation of the device layout of a model (no CUDA needed):
//  - samples reordered along a Morton (Z-order) curve of their rest positions, so that the
//    samples of one thread block touch few, nearby frames and neighbouring threads read nearby
//    memory (the device results are per frame and do not depend on the sample order beyond
//    rounding);
//  - the block tables of the force and tangent passes (elasticity_phases.hpp): consecutive samples grouped
//    into blocks, each block's distinct frames ("slots") with the block-local pairs that touch
//    them, and per frame the slots that hold its partial sums. Every list is in increasing order,
//    which fixes the summation order and makes the device results bitwise reproducible;
//  - the coalesced tangent pass's per-block ELL order of pairs: pair j of the block's sample t sits at
//    j * ns + t (ns samples in the block, width = the block's largest neighbour count), so that
//    thread t reading its j-th pair and the warp's threads reading neighbouring words coincide:
//    every per-pair load and shared-memory store of that pass is coalesced.
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
// device passes rebuild l_p from rest positions (eq. 2 with rest orientation I).
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
  // Coalesced tangent pass (build_ell_order; ELL order within each block, entries past a
  // sample's count are padding). Empty unless built.
  std::vector<int> ell_offsets;         // [B+1] first ELL entry of each block; block b has ns_b * width_b
  std::vector<int> pair_ell;            // [P] ELL entry of each pair (global)
  std::vector<int> ell_slot;            // [E] slot of the entry's pair minus the block's first slot (0 on padding)
  // [E] the entry's position in the block's slot-major pair order (0 on padding): the coalesced
  // pass writes its outputs there, so each slot's pairs are contiguous for its sum, which adds
  // them in position order. Within its slot's range [slot_pair_offsets[q], [q + 1]) (minus the
  // block's first) a pair's position is chosen so that the threads of one warp store to distinct
  // shared-memory banks (interleave_positions).
  std::vector<int> ell_pos;
  int ell_count() const { return ell_offsets.empty() ? 0 : ell_offsets.back(); }
  int block_count() const { return static_cast<int>(block_samples.size()) - 1; }
  int slot_count() const { return static_cast<int>(slot_frames.size()); }
};

// Blocks of at most max_samples consecutive samples, max_pairs pairs and max_slots distinct frames
// (a sample with more pairs or frames than that gets a block of its own: there is no cap on
// neighbours).
BlockLayout build_block_layout(const Model& model, int max_samples, int max_pairs, int max_slots);

// Fills the ELL tables of the coalesced tangent pass into a layout of build_block_layout: pair j
// of a block's local sample t at entry j * ns + t, and the slot-major positions, interleaved for
// one thread per sample.
void build_ell_order(const Model& model, BlockLayout& layout);

// Shared-memory wavefronts of one component of the coalesced pass's pair-output stores over the
// whole layout, one thread per sample: for each warp and pair j of its 32 consecutive
// block-local samples, the most threads whose positions fall in one of the 32 four-byte banks
// (float outputs; a store of only distinct banks takes one wavefront).
long long coalesced_store_wavefronts(const Model& model, const BlockLayout& layout);

}  // namespace fascia::gpu
