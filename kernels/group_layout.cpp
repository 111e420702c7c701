#include "group_layout.hpp"

#include <algorithm>
#include <array>
#include <numeric>
#include <stdexcept>

namespace fascia::gpu {
namespace {

using FrameSet = std::array<int, kGroupLanes>;

// Sample s's frames in increasing order, -1 past its count (at most kGroupLanes frames).
FrameSet frame_set(const NeighbourTable& nb, int s) {
  FrameSet key;
  key.fill(-1);
  const int n = std::min(kGroupLanes, nb.offsets[s + 1] - nb.offsets[s]);
  for (int k = 0; k < n; ++k) {  // insertion sort: at most kGroupLanes values
    const int f = nb.frames[nb.offsets[s] + k];
    int j = k;
    for (; j > 0 && key[j - 1] > f; --j) key[j] = key[j - 1];
    key[j] = f;
  }
  return key;
}

}  // namespace

std::string group_refusal(const Model& model) {
  const NeighbourTable& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s) {
    const int n = nb.offsets[s + 1] - nb.offsets[s];
    if (n > kGroupLanes)
      return "sample " + std::to_string(s) + " has " + std::to_string(n) + " neighbour frames (the grouped pass takes at most " +
             std::to_string(kGroupLanes) + ")";
    const FrameSet key = frame_set(nb, s);
    if (std::adjacent_find(key.begin(), key.begin() + n) != key.begin() + n)
      return "sample " + std::to_string(s) + " lists a frame twice";
  }
  return {};
}

std::vector<int> group_sample_order(const Model& model, const std::vector<int>& order, double* mean_group_samples) {
  const NeighbourTable& nb = model.neighbours;
  const int S = model.sample_count();
  std::vector<FrameSet> keys(S);
  for (int s = 0; s < S; ++s) keys[s] = frame_set(nb, s);
  // Group ids: samples sorted by frame set, equal sets numbered together.
  std::vector<int> by_set(S), group(S);
  std::iota(by_set.begin(), by_set.end(), 0);
  std::sort(by_set.begin(), by_set.end(), [&](int a, int b) { return keys[a] != keys[b] ? keys[a] < keys[b] : a < b; });
  int groups = 0;
  for (int k = 0; k < S; ++k) {
    if (k > 0 && keys[by_set[k]] != keys[by_set[k - 1]]) ++groups;
    group[by_set[k]] = groups;
  }
  if (S > 0) ++groups;
  // Each group's samples in `order`'s order (CSR over groups).
  std::vector<int> offsets(groups + 1, 0), members(S);
  for (int s = 0; s < S; ++s) ++offsets[group[s] + 1];
  std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
  if (mean_group_samples) {
    long long split = 0;  // build_group_layout's groups: each set's samples in runs of kGroupLanes
    for (int g = 0; g < groups; ++g) split += (offsets[g + 1] - offsets[g] + kGroupLanes - 1) / kGroupLanes;
    *mean_group_samples = split > 0 ? static_cast<double>(S) / static_cast<double>(split) : 0.0;
  }
  std::vector<int> cursor(offsets.begin(), offsets.end() - 1);
  for (int s : order) members[cursor[group[s]]++] = s;
  // Within a group, samples by their weights in frame order (then in `order`'s): the samples at
  // one quadrature point of like elements take the same thread in every group.
  const auto weights = [&](int s) {
    std::array<double, kGroupLanes> w;
    w.fill(0.0);
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
      w[std::find(keys[s].begin(), keys[s].end(), nb.frames[p]) - keys[s].begin()] = nb.weights[p];
    return w;
  };
  std::vector<std::pair<std::array<double, kGroupLanes>, int>> keyed;  // one group's (weights, sample)
  for (int g = 0; g < groups; ++g) {
    keyed.clear();
    for (int k = offsets[g]; k < offsets[g + 1]; ++k) keyed.emplace_back(weights(members[k]), members[k]);
    // Equal weights keep `order`'s order: members are in it, and stable_sort keeps it.
    std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (size_t k = 0; k < keyed.size(); ++k) members[offsets[g] + k] = keyed[k].second;
  }
  std::vector<int> result;
  result.reserve(S);
  std::vector<char> placed(groups, 0);
  for (int s : order) {
    const int g = group[s];
    if (placed[g]) continue;
    placed[g] = 1;
    result.insert(result.end(), members.begin() + offsets[g], members.begin() + offsets[g + 1]);
  }
  return result;
}

double GroupLayout::mean_group_samples() const {
  return group_count() > 0 ? static_cast<double>(group_samples.back()) / group_count() : 0.0;
}

GroupLayout build_group_layout(const Model& model) {
  const NeighbourTable& nb = model.neighbours;
  const int S = model.sample_count();
  GroupLayout G;
  G.group_samples.push_back(0);
  FrameSet current{};
  for (int s = 0; s < S; ++s) {
    const FrameSet key = frame_set(nb, s);
    const int first = G.group_samples.back();
    if (s > first && (key != current || s - first == kGroupLanes)) G.group_samples.push_back(s);
    if (s == G.group_samples.back()) {
      current = key;
      G.group_frames.insert(G.group_frames.end(), key.begin(), key.end());
    }
  }
  if (S > 0) G.group_samples.push_back(S);
  const int groups = G.group_count();
  G.pair_entry.assign(nb.frames.size(), 0);
  for (int g = 0; g < groups; ++g)
    for (int s = G.group_samples[g]; s < G.group_samples[g + 1]; ++s)
      for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
        const int* list = &G.group_frames[kGroupLanes * static_cast<size_t>(g)];
        const int k = static_cast<int>(std::find(list, list + kGroupLanes, nb.frames[p]) - list);
        if (k == kGroupLanes) throw std::logic_error("build_group_layout: a sample outside its group's frame set");
        G.pair_entry[p] = k;
      }
  // The entries (g, k) as the pairs of a model whose samples are the groups: build_block_layout
  // then gives blocks of kGroupBlock groups (at most kGroupBlock kGroupLanes entries and slots,
  // never binding) and their slot tables.
  Model entries;
  entries.frame_rest_positions = model.frame_rest_positions;
  entries.samples.volumes.assign(groups, 0.0);
  NeighbourTable& en = entries.neighbours;
  en.offsets.push_back(0);
  for (int g = 0; g < groups; ++g) {
    for (int k = 0; k < kGroupLanes; ++k)
      if (G.group_frames[kGroupLanes * static_cast<size_t>(g) + k] >= 0)
        en.frames.push_back(G.group_frames[kGroupLanes * static_cast<size_t>(g) + k]);
    en.offsets.push_back(static_cast<int>(en.frames.size()));
  }
  constexpr int kEntries = kGroupBlock * kGroupLanes;
  G.slots = build_block_layout(entries, kGroupBlock, kEntries, kEntries);
  for (int b = 0; b < G.slots.block_count(); ++b)  // the kernel takes block b's groups as [b kGroupBlock, ...)
    if (G.slots.block_samples[b] != b * kGroupBlock)
      throw std::logic_error("build_group_layout: a block that is not kGroupBlock consecutive groups");
  G.entry_pos.assign(kGroupLanes * static_cast<size_t>(groups), 0);
  const BlockLayout& L = G.slots;
  G.slot_store.assign(L.slot_count(), 0);
  for (int k = 0; k < L.slot_count(); ++k) G.slot_store[L.frame_slots[k]] = k;
  for (int b = 0; b < L.block_count(); ++b) {
    const int g0 = L.block_samples[b], p0 = en.offsets[g0];
    const int k0 = L.slot_pair_offsets[L.block_slots[b]], k1 = L.slot_pair_offsets[L.block_slots[b + 1]];
    int g = g0;
    for (int j = k0; j < k1; ++j) {
      const int p = p0 + L.slot_pairs[j];
      g = static_cast<int>(std::upper_bound(en.offsets.begin() + g0, en.offsets.end(), p) - en.offsets.begin()) - 1;
      G.entry_pos[kGroupLanes * static_cast<size_t>(g) + (p - en.offsets[g])] = j - k0;
    }
  }
  return G;
}

}  // namespace fascia::gpu
