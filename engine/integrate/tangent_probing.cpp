#include "integrate/tangent_probing.hpp"

#include <algorithm>

namespace fascia {
namespace {

// The frame coupling graph of the reduced tangent: adjacency lists, sorted, each unknown frame
// its own neighbour. Mapped frames are replaced by their bodies and have empty lists.
std::vector<std::vector<int>> coupling_graph(const Model& model) {
  const size_t n = static_cast<size_t>(model.frame_count());
  std::vector<int> unknown(n);
  for (size_t i = 0; i < n; ++i) {
    const bool mapped = !model.rigid_parents.empty() && model.rigid_parents[i] >= 0;
    unknown[i] = mapped ? model.rigid_parents[i] : static_cast<int>(i);
  }
  // The frames of each coupling group (a sample's frames, a shell triangle's), and the groups of
  // each unknown frame.
  std::vector<std::vector<int>> groups;
  const auto& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s) {
    std::vector<int> g;
    for (int p = nb.offsets[static_cast<size_t>(s)]; p < nb.offsets[static_cast<size_t>(s) + 1]; ++p)
      g.push_back(unknown[static_cast<size_t>(nb.frames[static_cast<size_t>(p)])]);
    groups.push_back(std::move(g));
  }
  for (const Shell& shell : model.shells)
    for (size_t t = 0; t + 2 < shell.triangles.size(); t += 3)
      groups.push_back({unknown[static_cast<size_t>(shell.triangles[t])], unknown[static_cast<size_t>(shell.triangles[t + 1])],
                        unknown[static_cast<size_t>(shell.triangles[t + 2])]});
  std::vector<std::vector<int>> member(n);
  for (size_t g = 0; g < groups.size(); ++g)
    for (int f : groups[g])
      if (member[static_cast<size_t>(f)].empty() || member[static_cast<size_t>(f)].back() != static_cast<int>(g))
        member[static_cast<size_t>(f)].push_back(static_cast<int>(g));
  // Union of each frame's groups, deduplicated with a stamp per frame.
  std::vector<std::vector<int>> adjacent(n);
  std::vector<size_t> stamp(n, n);
  for (size_t i = 0; i < n; ++i) {
    if (unknown[i] != static_cast<int>(i)) continue;
    auto& a = adjacent[i];
    a.push_back(static_cast<int>(i));
    stamp[i] = i;
    for (int g : member[i])
      for (int f : groups[static_cast<size_t>(g)])
        if (stamp[static_cast<size_t>(f)] != i) {
          stamp[static_cast<size_t>(f)] = i;
          a.push_back(f);
        }
    std::sort(a.begin(), a.end());
  }
  return adjacent;
}

}  // namespace

TangentProbing tangent_probing(const Model& model, int hub_degree) {
  const int n = model.frame_count();
  const std::vector<std::vector<int>> adjacent = coupling_graph(model);
  TangentProbing t;
  t.frames = n;
  t.colour.assign(static_cast<size_t>(n), -1);
  if (hub_degree <= 0) {
    std::vector<size_t> degrees;
    for (const auto& a : adjacent)
      if (!a.empty()) degrees.push_back(a.size());
    if (!degrees.empty()) {
      std::nth_element(degrees.begin(), degrees.begin() + static_cast<long>(degrees.size() / 2), degrees.end());
      hub_degree = kProbeHubFactor * static_cast<int>(degrees[degrees.size() / 2]);
    }
  }
  std::vector<char> hub(static_cast<size_t>(n), 0);
  for (int i = 0; i < n; ++i)
    hub[static_cast<size_t>(i)] = hub_degree > 0 && adjacent[static_cast<size_t>(i)].size() > static_cast<size_t>(hub_degree);

  // Greedy distance-2 colouring of the frames that are not hubs: frames j and j' conflict when a
  // row r that is not a hub couples to both. mark[c] == j: colour c is taken for frame j.
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
  return t;
}

}  // namespace fascia
