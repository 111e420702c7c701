// Host-side preparation of the device's assembled tangent blocks (k_tangent_blocks,
// device_elasticity.cu; no CUDA needed): the terms of each 6x6 block between frames a and b, the
// pairs (p_a, p_b) of the samples the two frames share.
#pragma once

#include "model/model.hpp"

#include <vector>

namespace fascia::gpu {

// The terms of the blocks of a tangent block pattern (integrate/tangent_probing.hpp: row frame a
// holds the blocks (a, block_frames[p]) for p in [block_offsets[a], block_offsets[a + 1])), CSR
// over the blocks: block p's terms are pairs[2 k], pairs[2 k + 1] = (p_a, p_b) for k in
// [offsets[p], offsets[p + 1]), frame a's pairs p_a in the order of the reverse table (increasing
// sample), and for each the pairs p_b of its sample in order. Blocks with b > a (the transposes of
// (b, a)) have none.
struct TangentTerms {
  std::vector<int> offsets;  // [B+1]
  std::vector<int> pairs;    // [2 C]
};

// From the neighbour table's offsets and frames and the reverse table of a model. Parallel over
// row frames; the result does not depend on the threads.
TangentTerms tangent_terms(const NeighbourTable& nb, const ReverseTable& rev, const std::vector<int>& block_offsets,
                           const std::vector<int>& block_frames);

}  // namespace fascia::gpu
