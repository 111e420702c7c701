// Dense background grid for Poisson-disk point sets (Bridson 2007): cells of size r / sqrt(3),
// so that two points at least r apart never share a cell and each cell stores one point index.
// Used for the disk test while sampling and for nearest-point queries afterwards.
//
// The grid is padded with `reach` empty cells on every side, so neighbour lookups need no bounds
// checks: a neighbour cell is the centre cell's linear index plus a precomputed delta.
#pragma once

#include "core/small_math.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace fascia {

class PointGrid {
 public:
  // Covers [lower, upper] with cells of size `cell` (m); `reach` = how many cells away queries
  // may look (the offset table holds the (2 reach + 1)^3 neighbours sorted by distance).
  PointGrid(const Vec3& lower, const Vec3& upper, double cell, int reach) : m_cell(cell), m_reach(reach) {
    if (!(cell > 0)) throw std::invalid_argument("grid cell size must be positive");
    m_lower = lower - Vec3{reach * cell, reach * cell, reach * cell};
    const Vec3 extent = upper - lower;
    for (int k = 0; k < 3; ++k) {
      const double cells = std::ceil((&extent.x)[k] / cell) + 1 + 2 * reach;
      if (cells > 1e6) throw std::invalid_argument("point grid too fine for the domain");
      m_dims[k] = static_cast<int>(cells);
    }
    const double total = static_cast<double>(m_dims[0]) * m_dims[1] * m_dims[2];
    if (total > 4e9) throw std::invalid_argument("point grid too large (more than 4e9 cells)");
    m_cells.assign(static_cast<size_t>(total), -1);
    for (int a = -reach; a <= reach; ++a)
      for (int b = -reach; b <= reach; ++b)
        for (int c = -reach; c <= reach; ++c) {
          // Smallest distance from any point of the centre cell to any point of cell (a, b, c).
          const auto gap = [](int o) { return std::max(std::abs(o) - 1, 0); };
          const double d = cell * std::sqrt(double(gap(a) * gap(a) + gap(b) * gap(b) + gap(c) * gap(c)));
          m_offsets.push_back(Offset{linear(a, b, c), d});
        }
    std::stable_sort(m_offsets.begin(), m_offsets.end(),
                     [](const Offset& x, const Offset& y) { return x.min_distance < y.min_distance; });
  }

  // Cell index of x, or -1 when x lies outside [lower, upper] (the padding is not addressable).
  long long cell_of(const Vec3& x) const {
    const Vec3 d = x - m_lower;
    long long ijk[3];
    for (int k = 0; k < 3; ++k) {
      const double f = std::floor((&d.x)[k] / m_cell);
      if (f < m_reach || f >= m_dims[k] - m_reach) return -1;
      ijk[k] = static_cast<long long>(f);
    }
    return linear(ijk[0], ijk[1], ijk[2]);
  }

  int at(long long cell) const { return m_cells[static_cast<size_t>(cell)]; }
  void set(long long cell, int id) { m_cells[static_cast<size_t>(cell)] = id; }

  // True when a point of `points` ([M][3]) lies closer than r to x, x in cell `cell`
  // (r must not exceed the reach).
  bool any_within(const Vec3& x, long long cell, double r, const std::vector<double>& points) const {
    const double r2 = r * r;
    for (const Offset& o : m_offsets) {
      if (o.min_distance >= r) break;
      const int id = m_cells[static_cast<size_t>(cell + o.delta)];
      if (id < 0) continue;
      const double* p = &points[3 * static_cast<size_t>(id)];
      const double dx = p[0] - x.x, dy = p[1] - x.y, dz = p[2] - x.z;
      if (dx * dx + dy * dy + dz * dz < r2) return true;
    }
    return false;
  }

  // Index of the point nearest to x within the reach, or -1; distance^2 in `d2`. x is clamped
  // into the covered box first (the lower bounds then shrink by the clamping distance).
  int nearest(const Vec3& x, const std::vector<double>& points, double& d2) const {
    d2 = 1e300;
    Vec3 y = x;
    for (int k = 0; k < 3; ++k) {
      const double lo = (&m_lower.x)[k] + m_reach * m_cell;
      const double hi = (&m_lower.x)[k] + (m_dims[k] - m_reach - 1e-6) * m_cell;
      (&y.x)[k] = std::clamp((&y.x)[k], lo, hi);
    }
    const long long cell = cell_of(y);
    if (cell < 0) return -1;
    const double extra = norm(y - x);
    int best = -1;
    for (const Offset& o : m_offsets) {
      const double lb = std::max(o.min_distance - extra, 0.0);
      if (best >= 0 && lb * lb > d2) break;
      const int id = m_cells[static_cast<size_t>(cell + o.delta)];
      if (id < 0) continue;
      const double* p = &points[3 * static_cast<size_t>(id)];
      const double dx = p[0] - x.x, dy = p[1] - x.y, dz = p[2] - x.z;
      const double e = dx * dx + dy * dy + dz * dz;
      if (e < d2) d2 = e, best = id;
    }
    return best;
  }

  double cell() const { return m_cell; }

 private:
  struct Offset {
    long long delta;
    double min_distance;
  };
  long long linear(long long i, long long j, long long k) const { return (i * m_dims[1] + j) * m_dims[2] + k; }

  Vec3 m_lower;
  double m_cell;
  int m_reach;
  std::array<int, 3> m_dims{};
  std::vector<int> m_cells;
  std::vector<Offset> m_offsets;
};

}  // namespace fascia
