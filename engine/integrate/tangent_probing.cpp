#include "integrate/tangent_probing.hpp"

#include <algorithm>

namespace fascia {
namespace {

void sort_unique(std::vector<int>& a) {
  std::sort(a.begin(), a.end());
  a.erase(std::unique(a.begin(), a.end()), a.end());
}

// The frame coupling graphs of the reduced tangent: adjacency lists, sorted, each unknown frame its
// own neighbour in `full` and `rest`; mapped frames have empty lists.
struct Couplings {
  std::vector<std::vector<int>> full;    // every coupling of H (mapped frames replaced by their bodies)
  std::vector<std::vector<int>> rest;    // the couplings outside the assembled blocks
  std::vector<std::vector<int>> blocks;  // the assembled blocks: unknowns that share a sample
};

Couplings couplings(const Model& model) {
  const size_t n = static_cast<size_t>(model.frame_count());
  std::vector<int> unknown(n);
  for (size_t i = 0; i < n; ++i) {
    const bool mapped = !model.rigid_parents.empty() && model.rigid_parents[i] >= 0;
    unknown[i] = mapped ? model.rigid_parents[i] : static_cast<int>(i);
  }
  Couplings g{std::vector<std::vector<int>>(n), std::vector<std::vector<int>>(n), std::vector<std::vector<int>>(n)};
  for (size_t i = 0; i < n; ++i)
    if (unknown[i] == static_cast<int>(i)) {
      g.full[i].push_back(static_cast<int>(i));
      g.rest[i].push_back(static_cast<int>(i));
    }
  auto couple = [](std::vector<std::vector<int>>& adjacent, const std::vector<int>& frames) {
    for (int a : frames) adjacent[static_cast<size_t>(a)].insert(adjacent[static_cast<size_t>(a)].end(), frames.begin(), frames.end());
  };
  // A sample couples its frames' unknowns (full); the unknowns among its own frames are the
  // assembled blocks; a body that carries one of its frames couples to all its unknowns (rest).
  const auto& nb = model.neighbours;
  std::vector<int> unknowns, free, bodies;
  for (int s = 0; s < model.sample_count(); ++s) {
    unknowns.clear();
    free.clear();
    bodies.clear();
    for (int p = nb.offsets[static_cast<size_t>(s)]; p < nb.offsets[static_cast<size_t>(s) + 1]; ++p) {
      const int f = nb.frames[static_cast<size_t>(p)], u = unknown[static_cast<size_t>(f)];
      unknowns.push_back(u);
      (u == f ? free : bodies).push_back(u);
    }
    couple(g.full, unknowns);
    couple(g.blocks, free);
    for (int b : bodies)
      for (int u : unknowns) {
        g.rest[static_cast<size_t>(b)].push_back(u);
        g.rest[static_cast<size_t>(u)].push_back(b);
      }
  }
  for (const Shell& shell : model.shells)
    for (size_t t = 0; t + 2 < shell.triangles.size(); t += 3) {
      const std::vector<int> frames{unknown[static_cast<size_t>(shell.triangles[t])],
                                    unknown[static_cast<size_t>(shell.triangles[t + 1])],
                                    unknown[static_cast<size_t>(shell.triangles[t + 2])]};
      couple(g.full, frames);
      couple(g.rest, frames);
    }
  for (size_t i = 0; i < n; ++i) {
    sort_unique(g.full[i]);
    sort_unique(g.rest[i]);
    sort_unique(g.blocks[i]);
  }
  return g;
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
    for (const auto& a : g.full)
      if (!a.empty()) degrees.push_back(a.size());
    if (!degrees.empty()) {
      std::nth_element(degrees.begin(), degrees.begin() + static_cast<long>(degrees.size() / 2), degrees.end());
      hub_degree = kProbeHubFactor * static_cast<int>(degrees[degrees.size() / 2]);
    }
  }
  std::vector<char> hub(static_cast<size_t>(n), 0);
  for (int i = 0; i < n; ++i)
    hub[static_cast<size_t>(i)] = hub_degree > 0 && g.full[static_cast<size_t>(i)].size() > static_cast<size_t>(hub_degree);

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
  return t;
}

}  // namespace fascia
