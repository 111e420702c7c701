// Host-side preparation of the grouped tangent pass (group_pass.hpp; no CUDA needed).
//
// A group is a set of samples whose neighbour frames are the same set: the 8 samples of a
// hexahedron of a mesh-based model share its 8 corner frames, the samples of a tetrahedron its 4.
// The grouped pass runs kGroupLanes threads per group, one per sample, and reads each frame once
// per group instead of once per pair; the group's pair outputs are summed per frame across its
// threads in registers before they meet the other groups of the block in shared memory.
//  - group_sample_order: samples reordered so that every group's samples are consecutive, groups
//    in the order of their first sample in a given order (the Morton order: groups stay near in
//    space);
//  - build_group_layout: the groups of a model in that order, blocks of kGroupBlock groups, and per
//    block the slot tables over its (group, frame) entries, so that the block's entries of one
//    frame ("slot", as in sample_layout.hpp) are summed in a fixed order.
#pragma once

#include "model/model.hpp"
#include "sample_layout.hpp"

#include <string>
#include <vector>

namespace fascia::gpu {

constexpr int kGroupLanes = 8;   // threads per group: at most this many samples and frames
constexpr int kGroupBlock = 16;  // groups per thread block (128 threads)

// Why the model cannot run the grouped pass (a sample with more than kGroupLanes frames), or empty.
std::string group_refusal(const Model& model);

// The permutation of samples that makes every group's samples consecutive: new sample k is old
// sample result[k]. Samples are visited in `order`; a sample whose group has not been placed yet
// places its whole group there (its samples ordered by their weights in frame order, then in
// `order`'s order). A group of more than kGroupLanes
// samples is split, by build_group_layout, into consecutive groups of at most kGroupLanes. With
// `mean_group_samples`, also the mean samples per group of that split (GroupLayout's
// mean_group_samples of the model in this order), known before the model is reordered.
// Requires group_refusal(model) to be empty.
std::vector<int> group_sample_order(const Model& model, const std::vector<int>& order,
                                    double* mean_group_samples = nullptr);

// The fewest samples per group on average for which the grouped pass runs: below it most of its
// threads would be idle.
constexpr double kMinGroupSamples = 2.0;

struct GroupLayout {
  std::vector<int> group_samples;  // [G+1] first sample of each group (its samples are consecutive)
  // [G][kGroupLanes] the group's frames in increasing order, -1 past its frame count.
  std::vector<int> group_frames;
  // Blocks of kGroupBlock consecutive groups and their slots. `slots` is a BlockLayout over the
  // entries (g, k) (group g, its k-th frame) in place of pairs: slots.block_samples holds the
  // blocks' first groups, slots.slot_pairs the block-local entries in CSR order (a group's entries
  // follow the previous groups' in the block), and slots.frame_slot_offsets / frame_slots the
  // frames' slots, as k_frame_sums reads them.
  BlockLayout slots;
  // [Q] the slots in frame-major order: slot q's partials are stored at slot_store[q], so that
  // frame i's are at [slots.frame_slot_offsets[i], [i + 1]), in slots.frame_slots' order.
  std::vector<int> slot_store;
  // [G][kGroupLanes] slot-major position of entry (g, k) in its block (its slot's range; 0 past
  // the group's frame count).
  std::vector<int> entry_pos;
  // [P] per pair: k, the index of its frame in its group's list.
  std::vector<int> pair_entry;
  int group_count() const { return static_cast<int>(group_samples.size()) - 1; }
  int block_count() const { return slots.block_count(); }
  // Mean samples per group.
  double mean_group_samples() const;
};

// The groups of a model whose samples are in group order (group_sample_order): each maximal run of
// consecutive samples with the same frame set, split into groups of at most kGroupLanes samples.
// Requires group_refusal(model) to be empty.
GroupLayout build_group_layout(const Model& model);

}  // namespace fascia::gpu
