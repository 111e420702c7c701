// Recovering the step tangent H (6N x 6N, of the reduced potential of step_potential.hpp) from its
// blocks between frames that are unknowns, assembled term by term, and a few products H e for the
// rigid bodies (Curtis, Powell & Reid 1974; Coleman & More 1983).
//
// Between two unknowns a and b that are not rigid bodies, H_ab is the sum of the terms that hold
// both: the elasticity's samples (eq. 18, v_s B_a^T D_s B_b and, for a == b, the rotational
// geometric block), the shells' triangles, and for a == b the frame terms (inertia, damping,
// loads). These are assembled into a block-sparse matrix (the "assembled blocks"): one block per
// two unknowns that share a sample or a triangle, and one per unknown on the diagonal.
//
// A rigid body's frame also takes, through the rigid mapping, the terms of every frame carried by
// it (J^T H J and the mapping's geometric term): it couples to every unknown that shares a sample
// or a triangle with one of those frames. Each body's six columns are read from six products, one
// per DOF component, each entry less the assembled blocks' share of it; its rows are taken from its
// columns by symmetry. The assembled blocks are then added. Between unknowns that are not bodies
// nothing is left to probe, so a model without rigid bodies needs no product.
//
// The host builds the pattern once per model; the per-entry rules below (FASCIA_HD) are what the
// device runs and what the host test checks against the assembled tangent.
#pragma once

#include "core/config.hpp"
#include "model/model.hpp"

#include <cstdint>
#include <vector>

namespace fascia {

struct TangentProbing {
  int frames = 0;
  // The frames probed: the rigid bodies that carry frames (the frames mapped to them), ascending.
  std::vector<int> bodies;
  // The assembled blocks, CSR over block rows: row frame a holds the blocks (a, b) for
  // b = block_frames[p], p in [block_offsets[a], block_offsets[a + 1]), increasing b. Each block is
  // 6x6 row-major, H entry (6a + r, 6b + c) at 36 p + 6 r + c. Frames a and b are unknowns that
  // share a sample or a shell triangle, or a == b. The pattern is symmetric, and only the blocks
  // with b <= a hold values (H is symmetric: block (a, b) for b > a is the transpose of (b, a)).
  std::vector<int> block_offsets;  // [N+1]
  std::vector<int> block_frames;   // [B]
  std::vector<int> diagonal_blocks;  // [N] the block (a, a), -1 for frames mapped to a body
  // Where row frame f's block with body c lies, for probe_value: [bodies][N], p + 1 for block
  // (f, body) = p (body <= f), -(q + 1) for block (body, f) = q transposed (body > f), 0: none.
  std::vector<int> body_blocks;
};

// The pattern and the bodies of model's step tangent (frames mapped to rigid bodies are not
// unknowns).
TangentProbing tangent_probing(const Model& model);

// The probe vector of body frame `body` and component k (0..5) at DOF i: 1 on the body's DOF k
// unless it is fixed, 0 elsewhere.
FASCIA_HD double probe_entry(const std::uint8_t* fixed, int body, int k, int i) {
  return (i == 6 * body + k && !fixed[i]) ? 1.0 : 0.0;
}

// Where entry i of the product H e(body, k) belongs in H: column 6 body + k, and its transpose
// (the body's row); -1 at fixed rows.
FASCIA_HD long long probe_column(const std::uint8_t* fixed, int body, int k, int i) {
  return fixed[i] ? -1 : 6LL * body + k;
}

// The value of H at (i, 6 body + k) from entry i of the product H e(body, k): the entry less the
// assembled blocks' share of it. body_blocks_c: TangentProbing::body_blocks of this body, [N];
// blocks: the assembled blocks, [B][36].
FASCIA_HD double probe_value(double product_i, const std::uint8_t* fixed, const int* body_blocks_c,
                             const double* blocks, int body, int k, int i) {
  const int e = body_blocks_c[i / 6], r = i % 6;
  if (e == 0 || fixed[6 * body + k]) return product_i;
  return product_i - (e > 0 ? blocks[36LL * (e - 1) + 6 * r + k] : blocks[36LL * (-e - 1) + 6 * k + r]);
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
