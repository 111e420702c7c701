#include "sample_layout.hpp"

#include "core/morton_order.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>

namespace fascia::gpu {
namespace {

// Calls visit(e) for the ELL entries that one warp of the coalesced pass stores together, group
// by group, calling end_group() after each: pair j of 32 consecutive block-local samples (one
// thread each).
template <class Visit, class EndGroup>
void for_each_store_group(const NeighbourTable& nb, const BlockLayout& L, int b, Visit visit, EndGroup end_group) {
  const int s0 = L.block_samples[b], ns = L.block_samples[b + 1] - s0;
  for (int t0 = 0; t0 < ns; t0 += 32) {
    const int t1 = std::min(ns, t0 + 32);
    int width = 0;
    for (int t = t0; t < t1; ++t) width = std::max(width, nb.offsets[s0 + t + 1] - nb.offsets[s0 + t]);
    for (int j = 0; j < width; ++j) {
      for (int t = t0; t < t1; ++t)
        if (j < nb.offsets[s0 + t + 1] - nb.offsets[s0 + t]) visit(L.pair_ell[nb.offsets[s0 + t] + j]);
      end_group();
    }
  }
}

// Slot-major positions of block b's entries (BlockLayout::ell_pos): every pair of slot q gets a
// position in the slot's range [a, a + n), and the pairs of one store group (for_each_store_group)
// take distinct residues modulo 32 (distinct banks) where their slots' free positions allow,
// greedily in the groups' order: each pair takes the free residue nearest after its slot's next
// position in sequence, else the free position whose residue the group holds least often.
void interleave_positions(const NeighbourTable& nb, BlockLayout& L, int b) {
  const int q0 = L.block_slots[b], nq = L.block_slots[b + 1] - q0, k0 = L.slot_pair_offsets[q0];
  std::vector<std::array<int, 32>> taken(nq);  // per slot and residue: positions given so far
  std::vector<int> given(nq, 0);               // per slot: positions given so far
  for (auto& t : taken) t.fill(0);
  std::array<int, 32> held{};  // per residue: the current group's positions
  const auto position = [&](int q, int r) {  // the next free position of slot q with residue r, or -1
    const int a = L.slot_pair_offsets[q0 + q] - k0, e = L.slot_pair_offsets[q0 + q + 1] - k0;
    const int p = a + ((r - a) % 32 + 32) % 32 + 32 * taken[q][r];
    return p < e ? p : -1;
  };
  for_each_store_group(
      nb, L, b,
      [&](int e) {
        const int q = L.ell_slot[e];
        const int a = L.slot_pair_offsets[q0 + q] - k0;
        const int first = (a + given[q]) % 32;
        int best = -1;
        for (int k = 0; k < 32; ++k) {
          const int r = (first + k) % 32;
          if (position(q, r) < 0) continue;
          if (best < 0 || held[r] < held[best]) best = r;
          if (held[r] == 0) break;
        }
        L.ell_pos[e] = position(q, best);
        ++taken[q][best];
        ++given[q];
        ++held[best];
      },
      [&] { held.fill(0); });
}

}  // namespace

std::vector<int> spatial_sample_order(const Model& model) { return morton_order(model.samples.rest_positions); }

Model reorder_samples(const Model& model, const std::vector<int>& order) {
  Model out;
  out.frame_rest_positions = model.frame_rest_positions;
  out.materials = model.materials;
  out.frame_masses = model.frame_masses;
  out.frame_inertias = model.frame_inertias;
  out.fixed_dofs = model.fixed_dofs;
  out.rotations_locked = model.rotations_locked;
  const NeighbourTable& nb = model.neighbours;
  NeighbourTable& o = out.neighbours;
  o.offsets.reserve(nb.offsets.size());
  o.offsets.push_back(0);
  for (int s : order) {
    out.samples.rest_positions.insert(out.samples.rest_positions.end(), &model.samples.rest_positions[3 * s],
                                      &model.samples.rest_positions[3 * s] + 3);
    out.samples.volumes.push_back(model.samples.volumes[s]);
    out.samples.materials.push_back(model.samples.materials[s]);
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      o.frames.push_back(nb.frames[p]);
      o.weights.push_back(nb.weights[p]);
      o.weight_gradients.insert(o.weight_gradients.end(), &nb.weight_gradients[3 * p], &nb.weight_gradients[3 * p] + 3);
      o.rest_offsets.insert(o.rest_offsets.end(), &nb.rest_offsets[3 * p], &nb.rest_offsets[3 * p] + 3);
    }
    o.offsets.push_back(static_cast<int>(o.frames.size()));
  }
  build_reverse_table(out);
  return out;
}

bool offsets_are_rest_differences(const Model& model, double rel_tol) {
  const NeighbourTable& nb = model.neighbours;
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  for (double v : model.frame_rest_positions) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  const double tol = rel_tol * std::max(hi - lo, 1e-300);
  for (int s = 0; s < model.sample_count(); ++s)
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      const int i = nb.frames[p];
      for (int k = 0; k < 3; ++k) {
        const double l = model.samples.rest_positions[3 * s + k] - model.frame_rest_positions[3 * i + k];
        if (std::abs(l - nb.rest_offsets[3 * p + k]) > tol) return false;
      }
    }
  return true;
}

BlockLayout build_block_layout(const Model& model, int max_samples, int max_pairs, int max_slots) {
  BlockLayout L;
  const NeighbourTable& nb = model.neighbours;
  const int s_count = model.sample_count();
  const int n = model.frame_count();
  L.block_samples.push_back(0);
  std::vector<int> stamp(n, -1);  // the last block that counted the frame among its slots
  for (int s = 0; s < s_count;) {
    const int first = s, block = L.block_count();
    int slots = 0;
    while (s < s_count && s - first < max_samples &&
           (s == first || nb.offsets[s + 1] - nb.offsets[first] <= max_pairs)) {
      int added = 0;  // the sample's frames new to the block (stamped even where it ends the block:
                      // the next block, which starts with this sample, stamps them again)
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
        if (stamp[nb.frames[p]] != block) {
          stamp[nb.frames[p]] = block;
          ++added;
        }
      if (s > first && slots + added > max_slots) break;
      slots += added;
      ++s;
    }
    L.block_samples.push_back(s);
    L.max_block_pairs = std::max(L.max_block_pairs, nb.offsets[s] - nb.offsets[first]);
  }
  const int blocks = L.block_count();
  L.block_slots.push_back(0);
  L.slot_pair_offsets.push_back(0);
  // Each block's (frame, local pair), sorted (in parallel over blocks), then its slots in order.
  std::vector<std::pair<int, int>> frame_pairs(nb.frames.size());
#pragma omp parallel for schedule(dynamic, 16)
  for (int b = 0; b < blocks; ++b) {
    const int p0 = nb.offsets[L.block_samples[b]], p1 = nb.offsets[L.block_samples[b + 1]];
    for (int p = p0; p < p1; ++p) frame_pairs[static_cast<size_t>(p)] = {nb.frames[p], p - p0};
    std::sort(frame_pairs.begin() + p0, frame_pairs.begin() + p1);
  }
  for (int b = 0; b < blocks; ++b) {
    const int p0 = nb.offsets[L.block_samples[b]], p1 = nb.offsets[L.block_samples[b + 1]];
    const std::pair<int, int>* frame_pair = frame_pairs.data() + p0;
    const size_t count = static_cast<size_t>(p1 - p0);
    for (size_t k = 0; k < count; ++k) {
      if (k == 0 || frame_pair[k].first != frame_pair[k - 1].first) {
        if (k > 0) L.slot_pair_offsets.push_back(static_cast<int>(L.slot_pairs.size()));
        L.slot_frames.push_back(frame_pair[k].first);
      }
      L.slot_pairs.push_back(frame_pair[k].second);
    }
    if (count > 0) L.slot_pair_offsets.push_back(static_cast<int>(L.slot_pairs.size()));
    L.block_slots.push_back(static_cast<int>(L.slot_frames.size()));
  }
  // Frame -> its slots, in slot (= block) order.
  const int q_count = L.slot_count();
  L.frame_slot_offsets.assign(n + 1, 0);
  for (int q = 0; q < q_count; ++q) ++L.frame_slot_offsets[L.slot_frames[q] + 1];
  for (int i = 0; i < n; ++i) L.frame_slot_offsets[i + 1] += L.frame_slot_offsets[i];
  L.frame_slots.assign(q_count, 0);
  std::vector<int> cursor(L.frame_slot_offsets.begin(), L.frame_slot_offsets.end() - 1);
  for (int q = 0; q < q_count; ++q) L.frame_slots[cursor[L.slot_frames[q]]++] = q;
  return L;
}

void build_ell_order(const Model& model, BlockLayout& L) {
  const NeighbourTable& nb = model.neighbours;
  const int blocks = L.block_count();
  L.ell_offsets.assign(1, 0);
  L.pair_ell.assign(nb.frames.size(), 0);
  for (int b = 0; b < blocks; ++b) {
    const int s0 = L.block_samples[b], s1 = L.block_samples[b + 1], ns = s1 - s0;
    int width = 0;
    for (int s = s0; s < s1; ++s) width = std::max(width, nb.offsets[s + 1] - nb.offsets[s]);
    const int e0 = L.ell_offsets.back();
    for (int s = s0; s < s1; ++s)
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) L.pair_ell[p] = e0 + (p - nb.offsets[s]) * ns + (s - s0);
    L.ell_offsets.push_back(e0 + width * ns);
  }
  L.ell_slot.assign(L.ell_count(), 0);
  L.ell_pos.assign(L.ell_count(), 0);
  // Each block writes its own entries only.
#pragma omp parallel for schedule(dynamic, 4)
  for (int b = 0; b < blocks; ++b) {
    const int p0 = nb.offsets[L.block_samples[b]], q0 = L.block_slots[b];
    for (int q = q0; q < L.block_slots[b + 1]; ++q)
      for (int k = L.slot_pair_offsets[q]; k < L.slot_pair_offsets[q + 1]; ++k)
        L.ell_slot[L.pair_ell[p0 + L.slot_pairs[k]]] = q - q0;
    interleave_positions(nb, L, b);
  }
}

long long coalesced_store_wavefronts(const Model& model, const BlockLayout& L) {
  long long wavefronts = 0;
  std::array<int, 32> held{};
  for (int b = 0; b < L.block_count(); ++b)
    for_each_store_group(
        model.neighbours, L, b, [&](int e) { ++held[L.ell_pos[e] % 32]; },
        [&] {
          wavefronts += *std::max_element(held.begin(), held.end());
          held.fill(0);
        });
  return wavefronts;
}

}  // namespace fascia::gpu
