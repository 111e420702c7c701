// Recovering the step tangent H (6N x 6N, of the reduced potential of step_potential.hpp) from its
// elastic blocks, assembled per sample, and a few products H e for the rest (Curtis, Powell & Reid
// 1974; Coleman & More 1983).
//
// The elasticity (eq. 18) couples every two frames that share a sample: with a meshless tissue's
// dozen frames per sample, each frame meets a hundred others, and a colouring of that graph needs
// hundreds of colours. Its blocks between frames that are unknowns (not mapped to a rigid body),
// v_s B_a^T D_s B_b summed over the samples of frames a and b, are instead assembled sample by
// sample into a block-sparse matrix (the "assembled blocks"). What they leave of H (the
// diagonal frame terms, shell triangles, a rigid body's couplings through the frames it carries)
// couples few frames: the columns of frames that no row couples to twice in that rest are probed
// together, one product per colour and per DOF component, and each entry of a product, less the
// assembled blocks' share of it, is returned to the one column of its colour that its row couples
// to. The assembled blocks are then added.
//
// A rigid body's frame takes the couplings of every frame attached to it (the rigid mapping),
// which makes it a hub coupled to hundreds of frames. A hub is probed alone and its rows are
// taken from its columns by symmetry, so that its neighbours need not all have distinct colours.
//
// The host builds the colouring and the block pattern once per model; the per-entry rules below
// (FASCIA_HD) are what the device runs and what the host test checks against the assembled tangent.
#pragma once

#include "core/config.hpp"
#include "model/model.hpp"

#include <cstdint>
#include <vector>

namespace fascia {

// A frame coupled outside the assembled blocks to more than this many times the median number of
// frames that such a frame couples to (of the frames coupled to any other) is probed alone (a
// hub): the colour count of the other frames then follows the shells' neighbourhoods, not the
// bodies' attachments.
inline constexpr int kProbeHubFactor = 4;

struct TangentProbing {
  int frames = 0;
  int colours = 0;
  std::vector<int> colour;     // [N] probe colour of each frame; -1: not probed (mapped to a rigid body)
  std::vector<int> hub_frame;  // [colours] the frame a hub colour probes, -1 for the other colours
  std::vector<int> owner;      // [colours][N] the frame of colour c that frame r couples to outside the
                               // assembled blocks, -1: none (and -1 in every hub frame's row: hub rows
                               // come from hub columns)
  // The assembled blocks, CSR over block rows: row frame a holds the blocks (a, b) for
  // b = block_frames[p], p in [block_offsets[a], block_offsets[a + 1]), increasing b. Each block is
  // 6x6 row-major, H entry (6a + r, 6b + c) at 36 p + 6 r + c. Frames a and b are unknowns that
  // share a sample (a == b included). The pattern is symmetric, and only the blocks with b <= a
  // hold values (H is symmetric: block (a, b) for b > a is the transpose of (b, a)).
  std::vector<int> block_offsets;  // [N+1]
  std::vector<int> block_frames;   // [B]
  // Row f's blocks whose column frame j has colour c, for probe_value: CSR over (f, c), entries
  // [colour_block_offsets[f colours + c], colour_block_offsets[f colours + c + 1]) in increasing j,
  // each with its frame j and where its values lie: colour_blocks p >= 0 for block (f, j) = p
  // (j <= f), -(q + 1) for block (j, f) = q transposed (j > f).
  std::vector<int> colour_block_offsets;  // [N colours + 1]
  std::vector<int> colour_block_frames;   // [B]
  std::vector<int> colour_blocks;         // [B]
};

// The colouring and the block pattern of model's step tangent (frames mapped to rigid bodies are
// not unknowns); frames coupled to more than hub_degree frames outside the blocks are hubs (0:
// kProbeHubFactor times the median).
TangentProbing tangent_probing(const Model& model, int hub_degree = 0);

// The probe vector of colour c and component k (0..5) at DOF i: 1 on DOF k of the colour's
// frames, 0 elsewhere and on fixed DOFs.
FASCIA_HD double probe_entry(const int* colour, const std::uint8_t* fixed, int c, int k, int i) {
  return (i % 6 == k && colour[i / 6] == c && !fixed[i]) ? 1.0 : 0.0;
}

// Where entry i of the product H e(c, k) belongs in H (column-major, n rows): the column of its
// row's frame of colour c, or -1 (a fixed row, a hub's row of another colour, no coupled frame).
// A hub colour's product is the hub's column, stored as its row as well (mirror = true).
FASCIA_HD long long probe_column(const int* owner_c, int hub_frame_c, const std::uint8_t* fixed, int k, int i,
                                 bool& mirror) {
  mirror = false;
  if (fixed[i]) return -1;
  if (hub_frame_c >= 0) {
    mirror = true;
    return 6LL * hub_frame_c + k;
  }
  const int j = owner_c[i / 6];
  return j >= 0 ? 6LL * j + k : -1;
}

// The value of H at (i, probe_column) from entry i of the product H e(c, k): the entry less the
// assembled blocks' share of it, row i's entries in the columns that e(c, k) sets.
// colour_block_offsets, colour_block_frames, colour_blocks: TangentProbing's, of `colours`
// colours; blocks: the assembled blocks (TangentProbing), [B][36].
FASCIA_HD double probe_value(double product_i, const std::uint8_t* fixed, const int* colour_block_offsets,
                             const int* colour_block_frames, const int* colour_blocks, const double* blocks, int colours,
                             int c, int k, int i) {
  const int f = i / 6, r = i % 6;
  const long long at = static_cast<long long>(f) * colours + c;
  for (int e = colour_block_offsets[at]; e < colour_block_offsets[at + 1]; ++e) {
    if (fixed[6 * colour_block_frames[e] + k]) continue;
    const int p = colour_blocks[e];
    product_i -= p >= 0 ? blocks[36LL * p + 6 * r + k] : blocks[36LL * (-p - 1) + 6 * k + r];
  }
  return product_i;
}

// The position p of block (a, b) among the assembled blocks, -1 when it is not one (a binary
// search of row a).
FASCIA_HD int assembled_block(const int* block_offsets, const int* block_frames, int a, int b) {
  int lo = block_offsets[a], hi = block_offsets[a + 1];
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (block_frames[mid] < b)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < block_offsets[a + 1] && block_frames[lo] == b ? lo : -1;
}

}  // namespace fascia
