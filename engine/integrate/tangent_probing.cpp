#include "integrate/tangent_probing.hpp"

#include <algorithm>

namespace fascia {

TangentProbing tangent_probing(const Model& model) {
  const int n = model.frame_count();
  const size_t frames = static_cast<size_t>(n);
  TangentProbing t;
  t.frames = n;
  // A frame mapped to a rigid body is not an unknown; its body is a probed frame.
  std::vector<char> mapped(frames, 0), body(frames, 0);
  for (size_t i = 0; i < model.rigid_parents.size(); ++i)
    if (model.rigid_parents[i] >= 0) {
      mapped[i] = 1;
      body[static_cast<size_t>(model.rigid_parents[i])] = 1;
    }
  for (int i = 0; i < n; ++i)
    if (body[static_cast<size_t>(i)]) t.bodies.push_back(i);

  // The coupling groups: each sample's frames, then each shell triangle's; each unknown's groups.
  const auto& nb = model.neighbours;
  std::vector<std::vector<int>> groups;
  for (int s = 0; s < model.sample_count(); ++s)
    groups.emplace_back(nb.frames.begin() + nb.offsets[static_cast<size_t>(s)],
                        nb.frames.begin() + nb.offsets[static_cast<size_t>(s) + 1]);
  for (const Shell& shell : model.shells)
    for (size_t k = 0; k + 2 < shell.triangles.size(); k += 3)
      groups.push_back({shell.triangles[k], shell.triangles[k + 1], shell.triangles[k + 2]});
  std::vector<std::vector<int>> member(frames);
  for (size_t g = 0; g < groups.size(); ++g)
    for (int f : groups[g]) {
      auto& m = member[static_cast<size_t>(f)];
      if (!mapped[static_cast<size_t>(f)] && (m.empty() || m.back() != static_cast<int>(g))) m.push_back(static_cast<int>(g));
    }

  // Row a: a itself and the unknowns of a's groups, deduplicated with a stamp per frame.
  std::vector<size_t> stamp(frames, frames);
  t.block_offsets.assign(1, 0);
  t.diagonal_blocks.assign(frames, -1);
  std::vector<int> row;
  for (size_t a = 0; a < frames; ++a) {
    row.clear();
    if (!mapped[a]) {
      row.push_back(static_cast<int>(a));
      stamp[a] = a;
      for (int g : member[a])
        for (int f : groups[static_cast<size_t>(g)])
          if (!mapped[static_cast<size_t>(f)] && stamp[static_cast<size_t>(f)] != a) {
            stamp[static_cast<size_t>(f)] = a;
            row.push_back(f);
          }
      std::sort(row.begin(), row.end());
      const auto self = std::lower_bound(row.begin(), row.end(), static_cast<int>(a));
      t.diagonal_blocks[a] = t.block_offsets.back() + static_cast<int>(self - row.begin());
    }
    t.block_frames.insert(t.block_frames.end(), row.begin(), row.end());
    t.block_offsets.push_back(static_cast<int>(t.block_frames.size()));
  }

  // Each row's block with each body, where the two share a group.
  t.body_blocks.assign(t.bodies.size() * frames, 0);
  for (size_t c = 0; c < t.bodies.size(); ++c) {
    const int j = t.bodies[c];
    for (int f = 0; f < n; ++f) {
      const int p = j <= f ? assembled_block(t.block_offsets.data(), t.block_frames.data(), f, j)
                           : assembled_block(t.block_offsets.data(), t.block_frames.data(), j, f);
      if (p >= 0) t.body_blocks[c * frames + static_cast<size_t>(f)] = j <= f ? p + 1 : -(p + 1);
    }
  }
  return t;
}

}  // namespace fascia
