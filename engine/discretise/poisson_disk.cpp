#include "discretise/poisson_disk.hpp"

#include "discretise/point_grid.hpp"

#include <nanoflann.hpp>

#include <cmath>
#include <stdexcept>

namespace fascia {
namespace {

struct PointCloud {  // nanoflann adaptor over [K][3]
  const std::vector<double>& xyz;
  size_t kdtree_get_point_count() const { return xyz.size() / 3; }
  double kdtree_get_pt(size_t i, size_t d) const { return xyz[3 * i + d]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};

using PointTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointCloud>, PointCloud, 3, int>;

}  // namespace

Random::Random(std::uint64_t seed) {
  for (std::uint64_t& s : m_s) {  // splitmix64
    seed += 0x9e3779b97f4a7c15ull;
    std::uint64_t z = seed;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    s = z ^ (z >> 31);
  }
}

std::uint64_t Random::next() {  // xoshiro256**
  const auto rotl = [](std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); };
  const std::uint64_t result = rotl(m_s[1] * 5, 7) * 9;
  const std::uint64_t t = m_s[1] << 17;
  m_s[2] ^= m_s[0];
  m_s[3] ^= m_s[1];
  m_s[1] ^= m_s[2];
  m_s[0] ^= m_s[3];
  m_s[2] ^= t;
  m_s[3] = rotl(m_s[3], 45);
  return result;
}

std::vector<double> poisson_disk_sample(const VoxelDomain& domain, const PoissonDiskOptions& options) {
  const double r = options.radius;
  if (!(r > 0)) throw std::invalid_argument("Poisson-disk radius must be positive");
  // Cells of r / sqrt(3): a cell holds at most one point; the disk test looks two cells away.
  PointGrid grid(domain.lower(), domain.upper(), r / std::sqrt(3.0), 2);
  VoxelDomain::Probe probe(domain);
  Random rng(options.seed);
  std::vector<double> points;
  std::vector<int> active;
  if (options.prescribed.size() % 3 != 0) throw std::invalid_argument("Poisson-disk prescribed points: [K][3]");
  const PointCloud cloud{options.prescribed};
  PointTree prescribed(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  prescribed.buildIndex();
  const bool any_prescribed = !options.prescribed.empty();

  // Accepts x if inside, in the grid and at least r from every point, prescribed ones included.
  const auto try_add = [&](const Vec3& x) {
    const long long cell = grid.cell_of(x);
    if (cell < 0 || grid.at(cell) >= 0) return false;  // an occupied cell is closer than r
    if (grid.any_within(x, cell, r, points)) return false;
    if (any_prescribed) {
      int nearest;
      double d2;
      prescribed.knnSearch(&x.x, 1, &nearest, &d2);
      if (d2 < r * r) return false;
    }
    if (!probe.inside(x)) return false;
    const int id = static_cast<int>(points.size() / 3);
    points.insert(points.end(), {x.x, x.y, x.z});
    grid.set(cell, id);
    active.push_back(id);
    return true;
  };

  // Candidates uniform in the shell r <= |d| < 2r around `centre`, until one is accepted.
  const auto try_around = [&](const Vec3& centre) {
    for (int a = 0; a < options.attempts; ++a) {
      // Uniform in the shell by rejection from the cube [-2r, 2r]^3 (acceptance 7 pi / 48),
      // drawn in units of r so that the test cannot overflow (r^2 is inf beyond 1.3e154 m).
      Vec3 u;
      double u2;
      do {
        u = 4.0 * Vec3{rng.uniform() - 0.5, rng.uniform() - 0.5, rng.uniform() - 0.5};
        u2 = dot(u, u);
      } while (u2 < 1 || u2 >= 4);
      if (try_add(centre + r * u)) return true;
    }
    return false;
  };

  // Bridson's front around a random active point.
  const auto grow = [&] {
    while (!active.empty()) {
      const size_t slot = static_cast<size_t>(rng.uniform() * static_cast<double>(active.size()));
      if (!try_around(load3(&points[3 * active[slot]]))) {
        active[slot] = active.back();
        active.pop_back();
      }
    }
  };

  // Fronts from the prescribed points first, each until it dies.
  for (size_t i = 0; i < options.prescribed.size() / 3; ++i)
    while (try_around(load3(&options.prescribed[3 * i]))) grow();

  // Seeds and gap filling: every interior voxel centre, in index order.
  std::vector<CoveredVoxel> voxels;
  for (int k = 0; k < domain.slice_count(); ++k) {
    voxels.clear();
    domain.covered_voxels(k, voxels);
    for (const CoveredVoxel& v : voxels) {
      if (v.fraction <= 0.5) continue;  // centre not inside
      if (try_add(v.centre)) grow();
    }
  }
  return points;
}

}  // namespace fascia
