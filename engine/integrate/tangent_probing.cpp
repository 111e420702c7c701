#include "integrate/tangent_probing.hpp"

#include <algorithm>
#include <utility>

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
  const int samples = model.sample_count();
  std::vector<const int*> triangles;
  for (const Shell& shell : model.shells)
    for (size_t k = 0; k + 2 < shell.triangles.size(); k += 3) triangles.push_back(&shell.triangles[k]);
  const auto group = [&](int g) -> std::pair<const int*, const int*> {
    if (g < samples) {
      const int* frames_of = nb.frames.data();
      return {frames_of + nb.offsets[static_cast<size_t>(g)], frames_of + nb.offsets[static_cast<size_t>(g) + 1]};
    }
    const int* corners = triangles[static_cast<size_t>(g - samples)];
    return {corners, corners + 3};
  };
  const int group_count = samples + static_cast<int>(triangles.size());
  std::vector<std::vector<int>> member(frames);
  for (int g = 0; g < group_count; ++g) {
    const auto [first, last] = group(g);
    for (const int* f = first; f != last; ++f) {
      auto& m = member[static_cast<size_t>(*f)];
      if (!mapped[static_cast<size_t>(*f)] && (m.empty() || m.back() != g)) m.push_back(g);
    }
  }

  // Row a: a itself and the unknowns of a's groups, deduplicated with a stamp per frame, sorted
  // (in parallel over rows), then the rows in order.
  std::vector<std::vector<int>> rows(frames);
#pragma omp parallel
  {
    std::vector<size_t> stamp(frames, frames);
#pragma omp for schedule(dynamic, 16)
    for (int ia = 0; ia < n; ++ia) {
      const size_t a = static_cast<size_t>(ia);
      if (mapped[a]) continue;
      std::vector<int>& row = rows[a];
      row.push_back(ia);
      stamp[a] = a;
      for (int g : member[a]) {
        const auto [first, last] = group(g);
        for (const int* f = first; f != last; ++f)
          if (!mapped[static_cast<size_t>(*f)] && stamp[static_cast<size_t>(*f)] != a) {
            stamp[static_cast<size_t>(*f)] = a;
            row.push_back(*f);
          }
      }
      std::sort(row.begin(), row.end());
    }
  }
  t.block_offsets.assign(1, 0);
  t.diagonal_blocks.assign(frames, -1);
  for (size_t a = 0; a < frames; ++a) {
    const std::vector<int>& row = rows[a];
    if (!mapped[a]) {
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
