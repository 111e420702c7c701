// Host-side checks of the grouped pass's layout (group_layout.hpp): no GPU needed.
#include "group_layout.hpp"
#include "group_pass.hpp"
#include "kernels_fixtures.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <numeric>

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

namespace {

std::vector<int> sorted_frames(const NeighbourTable& nb, int s) {
  std::vector<int> f(nb.frames.begin() + nb.offsets[s], nb.frames.begin() + nb.offsets[s + 1]);
  std::sort(f.begin(), f.end());
  return f;
}

}  // namespace

TEST_CASE("group order is a permutation that puts samples with the same frames together", "[kernels][layout]") {
  const CellType cell = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model input = kernels_test_model(cell, MaterialLaw::stvk, 5, 4, 3);
  REQUIRE(group_refusal(input).empty());
  const std::vector<int> morton = spatial_sample_order(input);
  double mean = 0;
  const std::vector<int> order = group_sample_order(input, morton, &mean);
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<int> identity(input.sample_count());
  std::iota(identity.begin(), identity.end(), 0);
  REQUIRE(sorted == identity);
  const Model model = reorder_samples(input, order);
  const GroupLayout G = build_group_layout(model);
  // The mean known before reordering is the layout's (the same counts, divided the same way).
  REQUIRE(mean == G.mean_group_samples());
  const NeighbourTable& nb = model.neighbours;
  REQUIRE(G.group_samples.front() == 0);
  REQUIRE(G.group_samples.back() == model.sample_count());
  int full = 0;
  for (int g = 0; g < G.group_count(); ++g) {
    const int s0 = G.group_samples[g], s1 = G.group_samples[g + 1];
    REQUIRE(s1 > s0);
    REQUIRE(s1 - s0 <= kGroupLanes);
    const std::vector<int> frames = sorted_frames(nb, s0);
    // The group's list: its frames in increasing order, then -1.
    for (int k = 0; k < kGroupLanes; ++k)
      REQUIRE(G.group_frames[kGroupLanes * g + k] == (k < static_cast<int>(frames.size()) ? frames[k] : -1));
    for (int s = s0; s < s1; ++s) {
      REQUIRE(sorted_frames(nb, s) == frames);
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
        REQUIRE(G.group_frames[kGroupLanes * g + G.pair_entry[p]] == nb.frames[p]);
    }
    // Groups are maximal: a group of fewer than kGroupLanes samples is followed by another set.
    if (s1 - s0 < kGroupLanes && s1 < model.sample_count()) REQUIRE(sorted_frames(nb, s1) != frames);
    full += s1 - s0 == kGroupLanes;
  }
  // Hexahedra: 2 x 2 x 2 samples per cell, one group each (the Morton order alone leaves some
  // cells' samples apart); tetrahedra: one sample per cell's frame set.
  if (cell == CellType::hexahedron) {
    REQUIRE(G.group_count() == model.sample_count() / 8);
    REQUIRE(full == G.group_count());
    REQUIRE(G.mean_group_samples() == 8.0);
  }
}

TEST_CASE("blocks of groups list every entry once, at a slot-major position in its slot's range", "[kernels][layout]") {
  const CellType cell = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const Model input = kernels_test_model(cell, MaterialLaw::stvk, 7, 5, 3);
  const Model model = reorder_samples(input, group_sample_order(input, spatial_sample_order(input)));
  const GroupLayout G = build_group_layout(model);
  const BlockLayout& L = G.slots;
  REQUIRE(L.block_samples.back() == G.group_count());
  int entries = 0;
  for (int b = 0; b < L.block_count(); ++b) {
    const int g0 = L.block_samples[b], g1 = L.block_samples[b + 1];
    REQUIRE(g1 - g0 <= kGroupBlock);
    if (b + 1 < L.block_count()) REQUIRE(g1 - g0 == kGroupBlock);
    const int q0 = L.block_slots[b], k0 = L.slot_pair_offsets[q0], k1 = L.slot_pair_offsets[L.block_slots[b + 1]];
    std::vector<int> at(k1 - k0, 0);
    for (int g = g0; g < g1; ++g)
      for (int k = 0; k < kGroupLanes; ++k) {
        const int frame = G.group_frames[kGroupLanes * g + k];
        if (frame < 0) continue;
        ++entries;
        const int pos = G.entry_pos[kGroupLanes * g + k];
        REQUIRE(pos >= 0);
        REQUIRE(pos < k1 - k0);
        ++at[pos];
        // The position lies in the range of the slot of the entry's frame.
        const int* first = &L.slot_frames[q0];
        const int* last = &L.slot_frames[0] + L.block_slots[b + 1];
        const int q = static_cast<int>(std::find(first, last, frame) - &L.slot_frames[0]);
        REQUIRE(q < L.block_slots[b + 1]);
        REQUIRE(pos >= L.slot_pair_offsets[q] - k0);
        REQUIRE(pos < L.slot_pair_offsets[q + 1] - k0);
      }
    REQUIRE(std::all_of(at.begin(), at.end(), [](int c) { return c == 1; }));
  }
  REQUIRE(entries == static_cast<int>(L.slot_pairs.size()));
  // Every frame's slots, in block order, stored frame-major: frame i's at
  // [frame_slot_offsets[i], [i + 1]).
  std::vector<int> stored(L.slot_count(), 0);
  for (int i = 0; i < model.frame_count(); ++i)
    for (int k = L.frame_slot_offsets[i]; k < L.frame_slot_offsets[i + 1]; ++k) {
      REQUIRE(L.slot_frames[L.frame_slots[k]] == i);
      if (k > L.frame_slot_offsets[i]) REQUIRE(L.frame_slots[k] > L.frame_slots[k - 1]);
      REQUIRE(G.slot_store[L.frame_slots[k]] == k);
      ++stored[k];
    }
  REQUIRE(std::all_of(stored.begin(), stored.end(), [](int c) { return c == 1; }));
}

TEST_CASE("group order reports the mean group size of models whose samples share no frames", "[kernels][layout]") {
  // Each frame set's first sample only: every group holds one sample (the device refuses the
  // grouped pass below kMinGroupSamples before reordering). With each set's sample repeated
  // kGroupLanes + 1 times, every set splits into a group of kGroupLanes and one of 1.
  const Model model = kernels_test_model(CellType::tetrahedron, MaterialLaw::stvk);
  std::vector<int> firsts;
  {
    std::vector<std::vector<int>> seen;
    for (int s = 0; s < model.sample_count(); ++s) {
      const std::vector<int> f = sorted_frames(model.neighbours, s);
      if (std::find(seen.begin(), seen.end(), f) == seen.end()) {
        seen.push_back(f);
        firsts.push_back(s);
      }
    }
  }
  const Model singles = reorder_samples(model, firsts);
  std::vector<int> identity(singles.sample_count());
  std::iota(identity.begin(), identity.end(), 0);
  double mean = 0;
  group_sample_order(singles, identity, &mean);
  CHECK(mean == 1.0);
  CHECK(mean < kMinGroupSamples);
  std::vector<int> repeated;
  for (int s : firsts)
    for (int k = 0; k <= kGroupLanes; ++k) repeated.push_back(s);
  const Model many = reorder_samples(model, repeated);
  std::vector<int> order(many.sample_count());
  std::iota(order.begin(), order.end(), 0);
  const std::vector<int> grouped = group_sample_order(many, order, &mean);
  CHECK(mean == static_cast<double>(kGroupLanes + 1) / 2.0);
  CHECK(mean == build_group_layout(reorder_samples(many, grouped)).mean_group_samples());
}

TEST_CASE("the grouped pass refuses samples it cannot hold", "[kernels][layout]") {
  Model model = kernels_test_model(CellType::tetrahedron, MaterialLaw::stvk);
  REQUIRE(group_refusal(model).empty());
  // A sample listing a frame twice.
  model.neighbours.frames[1] = model.neighbours.frames[0];
  CHECK(group_refusal(model).find("lists a frame twice") != std::string::npos);
}
