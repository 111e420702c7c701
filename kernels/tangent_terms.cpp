#include "tangent_terms.hpp"

namespace fascia::gpu {

TangentTerms tangent_terms(const NeighbourTable& nb, const ReverseTable& rev, const std::vector<int>& block_offsets,
                           const std::vector<int>& block_frames) {
  const int n = static_cast<int>(block_offsets.size()) - 1;
  const size_t blocks = block_frames.size();
  TangentTerms t;
  t.offsets.assign(blocks + 1, 0);
  // Row a's terms, blocks by column frame (position[b]: the block (a, b), b <= a), each term
  // handed to term(p, p_a, p_b).
  auto each_term = [&](int a, std::vector<int>& position, auto&& term) {
    const int first = block_offsets[static_cast<size_t>(a)], last = block_offsets[static_cast<size_t>(a) + 1];
    for (int p = first; p < last; ++p) {
      const int b = block_frames[static_cast<size_t>(p)];
      if (b <= a) position[static_cast<size_t>(b)] = p;
    }
    for (int r = rev.offsets[static_cast<size_t>(a)]; r < rev.offsets[static_cast<size_t>(a) + 1]; ++r) {
      const int pa = rev.pairs[static_cast<size_t>(r)], s = rev.pair_samples[static_cast<size_t>(pa)];
      for (int pb = nb.offsets[static_cast<size_t>(s)]; pb < nb.offsets[static_cast<size_t>(s) + 1]; ++pb) {
        const int p = position[static_cast<size_t>(nb.frames[static_cast<size_t>(pb)])];
        if (p >= 0) term(p, pa, pb);
      }
    }
    for (int p = first; p < last; ++p) position[static_cast<size_t>(block_frames[static_cast<size_t>(p)])] = -1;
  };
  // Counts (each row's blocks are its own), their prefix sums, then the terms at their places.
#pragma omp parallel
  {
    std::vector<int> position(static_cast<size_t>(n), -1);
#pragma omp for schedule(dynamic, 16)
    for (int a = 0; a < n; ++a)
      each_term(a, position, [&](int p, int, int) { ++t.offsets[static_cast<size_t>(p) + 1]; });
  }
  for (size_t p = 0; p < blocks; ++p) t.offsets[p + 1] += t.offsets[p];
  t.pairs.resize(2 * static_cast<size_t>(t.offsets[blocks]));
#pragma omp parallel
  {
    std::vector<int> position(static_cast<size_t>(n), -1), next;
#pragma omp for schedule(dynamic, 16)
    for (int a = 0; a < n; ++a) {
      const int first = block_offsets[static_cast<size_t>(a)], last = block_offsets[static_cast<size_t>(a) + 1];
      next.assign(t.offsets.begin() + first, t.offsets.begin() + last);
      each_term(a, position, [&](int p, int pa, int pb) {
        const size_t at = static_cast<size_t>(next[static_cast<size_t>(p - first)]++);
        t.pairs[2 * at] = pa;
        t.pairs[2 * at + 1] = pb;
      });
    }
  }
  return t;
}

}  // namespace fascia::gpu
