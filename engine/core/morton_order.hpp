// The order of points along a Morton (Z-order) curve: nearby points get nearby indices, so that
// loops over them read nearby memory. The curve's cells are cubes, 2^21 of them along the points'
// largest extent; points in one cell keep their order (deterministic).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

namespace fascia {

namespace morton_detail {

// Spreads the low 21 bits of v to every third bit.
inline std::uint64_t spread_bits(std::uint64_t v) {
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}

}  // namespace morton_detail

// points [M][3] (m); returns the permutation: point k of the order is points' order[k].
inline std::vector<int> morton_order(const std::vector<double>& points) {
  const int m = static_cast<int>(points.size() / 3);
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (int s = 0; s < m; ++s)
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], points[3 * s + k]);
      hi[k] = std::max(hi[k], points[3 * s + k]);
    }
  const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-300});
  const double scale = ((1 << 21) - 1) / extent;
  std::vector<std::uint64_t> code(m);
  for (int s = 0; s < m; ++s) {
    std::uint64_t c = 0;
    for (int k = 0; k < 3; ++k)
      c |= morton_detail::spread_bits(static_cast<std::uint64_t>((points[3 * s + k] - lo[k]) * scale)) << k;
    code[s] = c;
  }
  std::vector<int> order(m);
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return code[a] < code[b]; });
  return order;
}

}  // namespace fascia
