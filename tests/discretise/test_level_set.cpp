// Level sets derived from others: the tissue between two organs.
#include "discretise/level_set.hpp"
#include "discretise/voxel_domain.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

namespace {

// A closed octahedron-refined sphere: icosphere of radius r around c (outward triangles).
SurfaceMesh sphere(const Vec3& c, double r, int refinements = 4) {
  SurfaceMesh m;
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<Vec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                         {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<int> f = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8,
                        3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
  for (Vec3& p : v) p = (1 / norm(p)) * p;
  for (int r_ = 0; r_ < refinements; ++r_) {
    std::vector<int> g;
    for (std::size_t k = 0; k < f.size(); k += 3) {
      int m3[3];
      for (int e = 0; e < 3; ++e) {
        const Vec3 mid = 0.5 * (v[static_cast<std::size_t>(f[k + static_cast<std::size_t>(e)])] +
                                v[static_cast<std::size_t>(f[k + static_cast<std::size_t>((e + 1) % 3)])]);
        v.push_back((1 / norm(mid)) * mid);  // duplicates are harmless for meshToLevelSet
        m3[e] = static_cast<int>(v.size() - 1);
      }
      const int a = f[k], b = f[k + 1], cc = f[k + 2];
      g.insert(g.end(), {a, m3[0], m3[2], b, m3[1], m3[0], cc, m3[2], m3[1], m3[0], m3[1], m3[2]});
    }
    f = g;
  }
  for (const Vec3& p : v) {
    const Vec3 x = c + r * p;
    m.vertices.insert(m.vertices.end(), {x.x, x.y, x.z});
  }
  m.triangles = f;
  return m;
}

}  // namespace

TEST_CASE("the tissue between two organs lies within the distance of both and inside neither", "[level_set]") {
  // Two balls of radius 10 mm, centres 26 mm apart (gap 6 mm), tissue within 5 mm of both.
  const double h = 0.25e-3, d = 5e-3;
  const int band = static_cast<int>(std::ceil(d / h)) + 3;
  const LevelSet a = LevelSet::from_surface(sphere({0, 0, 0}, 10e-3), h, band);
  const LevelSet b = LevelSet::from_surface(sphere({26e-3, 0, 0}, 10e-3), h, band);
  const VoxelDomain tissue(LevelSet::between(a, b, d));
  // On the axis: the gap (10..16 mm) is within 5 mm of both balls where x in [11, 15] mm.
  CHECK(tissue.inside({13e-3, 0, 0}));
  CHECK(tissue.inside({11.5e-3, 0, 0}));
  CHECK(!tissue.inside({10.5e-3, 0, 0}));  // 10.5 mm from centre a: 5.5 mm from ball b
  CHECK(!tissue.inside({9e-3, 0, 0}));     // inside ball a
  CHECK(!tissue.inside({17e-3, 0, 0}));    // inside ball b
  // Off the axis at x = 13 mm: distance to both is sqrt(13^2 + y^2) - 10 <= 5 for y <= 7.2 mm.
  CHECK(tissue.inside({13e-3, 6.5e-3, 0}));
  CHECK(!tissue.inside({13e-3, 8e-3, 0}));
  // Within the stored band (3 h = 0.75 mm) the value is the CSG distance bound: at x = 11.5 mm,
  // max(1.5 - 5, 4.5 - 5, -1.5, -4.5) = -0.5 mm. Margin 0.1 mm: the icosphere's chord error
  // (about 0.05 mm) plus trilinear interpolation.
  CHECK(tissue.signed_distance({11.5e-3, 0, 0}) == Approx(-0.5e-3).margin(0.1e-3));
  // Volume: the region is a lens-shaped collar; it is positive and smaller than the shell of
  // thickness 5 mm around one ball (4/3 pi (15^3 - 10^3) mm^3).
  CHECK(tissue.volume() > 0);
  CHECK(tissue.volume() < 4.0 / 3.0 * M_PI * (3375 - 1000) * 1e-9);
  REQUIRE_THROWS_AS(LevelSet::between(a, LevelSet::from_surface(sphere({60e-3, 0, 0}, 10e-3), h, band), d),
                    std::invalid_argument);
  REQUIRE_THROWS_AS(LevelSet::between(a, LevelSet::from_surface(sphere({26e-3, 0, 0}, 10e-3), h, 3), d),
                    std::invalid_argument);
}
