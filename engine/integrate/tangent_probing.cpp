#include "integrate/tangent_probing.hpp"

#include <algorithm>

namespace fascia {
namespace {

// The frame coupling graphs of the reduced tangent: adjacency lists, sorted, each unknown frame its
// own neighbour in `rest`; mapped frames have empty lists.
struct Couplings {
  std::vector<std::vector<int>> rest;    // the couplings outside the assembled blocks (mapped frames
                                         // replaced by their bodies)
  std::vector<std::vector<int>> blocks;  // the assembled blocks: unknowns that share a sample
};

Couplings couplings(const Model& model) {
  const size_t n = static_cast<size_t>(model.frame_count());
  std::vector<int> unknown(n);
  for (size_t i = 0; i < n; ++i) {
    const bool mapped = !model.rigid_parents.empty() && model.rigid_parents[i] >= 0;
    unknown[i] = mapped ? model.rigid_parents[i] : static_cast<int>(i);
  }
  // The coupling groups: each sample's frames, then each shell triangle's; and the groups of each
  // frame as it is (a mapped frame's groups are its body's).
  const auto& nb = model.neighbours;
  const int samples = model.sample_count();
  std::vector<std::vector<int>> groups;
  for (int s = 0; s < samples; ++s)
    groups.emplace_back(nb.frames.begin() + nb.offsets[static_cast<size_t>(s)],
                        nb.frames.begin() + nb.offsets[static_cast<size_t>(s) + 1]);
  for (const Shell& shell : model.shells)
    for (size_t t = 0; t + 2 < shell.triangles.size(); t += 3)
      groups.push_back({shell.triangles[t], shell.triangles[t + 1], shell.triangles[t + 2]});
  std::vector<std::vector<int>> member(n);
  for (size_t g = 0; g < groups.size(); ++g)
    for (int f : groups[g]) {
      auto& m = member[static_cast<size_t>(unknown[static_cast<size_t>(f)])];
      if (m.empty() || m.back() != static_cast<int>(g)) m.push_back(static_cast<int>(g));
    }
  // A sample with a frame carried by a rigid body couples the body to all its frames' unknowns
  // outside the blocks; a sample of unknowns only couples them in the blocks.
  std::vector<char> carried(static_cast<size_t>(samples), 0);
  for (int s = 0; s < samples; ++s)
    for (int f : groups[static_cast<size_t>(s)]) carried[static_cast<size_t>(s)] |= unknown[static_cast<size_t>(f)] != f;

  Couplings c{std::vector<std::vector<int>>(n), std::vector<std::vector<int>>(n)};
  // Unions of each frame's groups, deduplicated with a stamp per frame and graph.
  std::vector<size_t> stamp_rest(n, n), stamp_block(n, n);
  auto add = [](std::vector<int>& row, std::vector<size_t>& stamp, size_t i, int f) {
    if (stamp[static_cast<size_t>(f)] == i) return;
    stamp[static_cast<size_t>(f)] = i;
    row.push_back(f);
  };
  for (size_t i = 0; i < n; ++i) {
    if (unknown[i] != static_cast<int>(i)) continue;
    add(c.rest[i], stamp_rest, i, static_cast<int>(i));
    for (int g : member[i]) {
      const std::vector<int>& frames = groups[static_cast<size_t>(g)];
      const bool sample = g < samples;
      // own: i is one of the group's frames; body: i carries one of them.
      bool own = false, body = false;
      for (int f : frames) {
        own |= f == static_cast<int>(i);
        body |= f != static_cast<int>(i) && unknown[static_cast<size_t>(f)] == static_cast<int>(i);
      }
      for (int f : frames) {
        const int u = unknown[static_cast<size_t>(f)];
        if (!sample) {
          add(c.rest[i], stamp_rest, i, u);
          continue;
        }
        if (own && u == f) add(c.blocks[i], stamp_block, i, f);
        if (carried[static_cast<size_t>(g)] && (body || u != f)) add(c.rest[i], stamp_rest, i, u);
      }
    }
    std::sort(c.rest[i].begin(), c.rest[i].end());
    std::sort(c.blocks[i].begin(), c.blocks[i].end());
  }
  return c;
}

}  // namespace

TangentProbing tangent_probing(const Model& model, int hub_degree) {
  const int n = model.frame_count();
  const Couplings g = couplings(model);
  const std::vector<std::vector<int>>& adjacent = g.rest;
  TangentProbing t;
  t.frames = n;
  t.colour.assign(static_cast<size_t>(n), -1);
  if (hub_degree <= 0) {
    std::vector<size_t> degrees;
    for (const auto& a : adjacent)
      if (a.size() > 1) degrees.push_back(a.size());
    if (!degrees.empty()) {
      std::nth_element(degrees.begin(), degrees.begin() + static_cast<long>(degrees.size() / 2), degrees.end());
      hub_degree = kProbeHubFactor * static_cast<int>(degrees[degrees.size() / 2]);
    }
  }
  std::vector<char> hub(static_cast<size_t>(n), 0);
  for (int i = 0; i < n; ++i)
    hub[static_cast<size_t>(i)] = hub_degree > 0 && adjacent[static_cast<size_t>(i)].size() > static_cast<size_t>(hub_degree);

  // Greedy distance-2 colouring of the rest's frames that are not hubs: frames j and j' conflict
  // when a row r that is not a hub couples to both outside the assembled blocks. mark[c] == j:
  // colour c is taken for frame j.
  std::vector<int> mark;
  for (int j = 0; j < n; ++j) {
    if (adjacent[static_cast<size_t>(j)].empty() || hub[static_cast<size_t>(j)]) continue;
    for (int r : adjacent[static_cast<size_t>(j)]) {
      if (hub[static_cast<size_t>(r)]) continue;
      for (int other : adjacent[static_cast<size_t>(r)]) {
        const int c = t.colour[static_cast<size_t>(other)];
        if (c >= 0) mark[static_cast<size_t>(c)] = j;
      }
    }
    int c = 0;
    while (c < t.colours && mark[static_cast<size_t>(c)] == j) ++c;
    if (c == t.colours) {
      ++t.colours;
      mark.push_back(-1);
    }
    t.colour[static_cast<size_t>(j)] = c;
  }
  t.hub_frame.assign(static_cast<size_t>(t.colours), -1);
  for (int j = 0; j < n; ++j)
    if (hub[static_cast<size_t>(j)]) {
      t.colour[static_cast<size_t>(j)] = t.colours++;
      t.hub_frame.push_back(j);
    }

  t.owner.assign(static_cast<size_t>(t.colours) * static_cast<size_t>(n), -1);
  for (int r = 0; r < n; ++r) {
    if (hub[static_cast<size_t>(r)]) continue;
    for (int j : adjacent[static_cast<size_t>(r)])
      if (!hub[static_cast<size_t>(j)]) t.owner[static_cast<size_t>(t.colour[static_cast<size_t>(j)]) * static_cast<size_t>(n) + static_cast<size_t>(r)] = j;
  }

  t.block_offsets.assign(1, 0);
  for (const auto& row : g.blocks) {
    t.block_frames.insert(t.block_frames.end(), row.begin(), row.end());
    t.block_offsets.push_back(static_cast<int>(t.block_frames.size()));
  }

  // Each row's blocks by the colour of their column frame (counting sort, stable in j).
  const size_t colours = static_cast<size_t>(t.colours);
  t.colour_block_offsets.assign(static_cast<size_t>(n) * colours + 1, 0);
  for (int f = 0; f < n; ++f)
    for (int p = t.block_offsets[static_cast<size_t>(f)]; p < t.block_offsets[static_cast<size_t>(f) + 1]; ++p) {
      const int j = t.block_frames[static_cast<size_t>(p)];
      ++t.colour_block_offsets[static_cast<size_t>(f) * colours + static_cast<size_t>(t.colour[static_cast<size_t>(j)]) + 1];
    }
  for (size_t e = 1; e < t.colour_block_offsets.size(); ++e) t.colour_block_offsets[e] += t.colour_block_offsets[e - 1];
  t.colour_block_frames.resize(t.block_frames.size());
  t.colour_blocks.resize(t.block_frames.size());
  std::vector<int> next(t.colour_block_offsets.begin(), t.colour_block_offsets.end() - 1);
  for (int f = 0; f < n; ++f)
    for (int p = t.block_offsets[static_cast<size_t>(f)]; p < t.block_offsets[static_cast<size_t>(f) + 1]; ++p) {
      const int j = t.block_frames[static_cast<size_t>(p)];
      const size_t e = static_cast<size_t>(
          next[static_cast<size_t>(f) * colours + static_cast<size_t>(t.colour[static_cast<size_t>(j)])]++);
      t.colour_block_frames[e] = j;
      t.colour_blocks[e] = j <= f ? p : -(assembled_block(t.block_offsets.data(), t.block_frames.data(), j, f) + 1);
    }
  return t;
}

}  // namespace fascia
