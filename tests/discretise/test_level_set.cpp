// Level sets from label images and derived from others (the tissue between two organs).
#include "bench/label_image_bench.hpp"
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

TEST_CASE("each label's level set holds its voxel count times the voxel volume at a lattice of one voxel edge",
          "[level_set][label_image]") {
  // Four labels (an ellipsoid, a ball of radius 10 voxels, a box, a torus of tube radius 4
  // voxels) in a 128^3 image of oblique 0.7 x 0.8 x 1.25 mm voxels, voxelised on the world lattice
  // of the smallest voxel edge, h = 0.7 mm: the lattice is neither aligned with the voxels nor as
  // fine as their longest edge.
  const LabelImage image = label_image_phantom(128);
  const double h = 0.7e-3;
  for (int label : {1, 2, 3, 4}) {
    CAPTURE(label);
    const double expected = static_cast<double>(image.count({label})) * image.voxel_volume();
    const LevelSet level_set = LevelSet::from_labels(image, {label}, h);
    // The goal of the label input: within 1 % of voxel count x voxel volume, for the volume the
    // discretisation distributes (voxel coverage) and OpenVDB's measure of the zero level set.
    // The distances are exact, so what remains is the coverage ramp's error at the staircase's
    // edges, O(h^2) per unit length with opposite signs at convex and concave edges (measured
    // here: -0.2 % to +0.2 %; with OpenVDB's renormalisation of the distances, up to +6 %).
    CHECK(VoxelDomain(level_set).volume() == Approx(expected).epsilon(0.01));
    CHECK(level_set.volume() == Approx(expected).epsilon(0.01));
  }
}

TEST_CASE("a region restricts the tissue between two organs", "[level_set]") {
  // The balls of the first test; the region is the half-space y <= 2 mm.
  const double h = 0.25e-3, d = 5e-3;
  const int band = static_cast<int>(std::ceil(d / h)) + 3;
  const LevelSet a = LevelSet::from_surface(sphere({0, 0, 0}, 10e-3), h, band);
  const LevelSet b = LevelSet::from_surface(sphere({26e-3, 0, 0}, 10e-3), h, band);
  const auto below = [](const Vec3& x) { return x.y - 2e-3; };
  const VoxelDomain whole(LevelSet::between(a, b, d));
  const VoxelDomain part(LevelSet::between(a, b, d, below));
  CHECK(part.inside({13e-3, 0, 0}));
  CHECK(part.inside({13e-3, -6.5e-3, 0}));
  CHECK(whole.inside({13e-3, 4e-3, 0}));
  CHECK(!part.inside({13e-3, 4e-3, 0}));
  // Within the band the value is the max of the two: at y = 1.5 mm, 0.5 mm inside the plane and
  // deeper in the tissue, -0.5 mm (margin: trilinear interpolation of a plane is exact, 1e-6 m
  // covers float storage).
  CHECK(part.signed_distance({13e-3, 1.5e-3, 0}) == Approx(-0.5e-3).margin(1e-6));
  // The collar is symmetric about y = 0 and the region cuts it at y = 2 mm: more than half of it
  // and less than all.
  CHECK(part.volume() > 0.5 * whole.volume());
  CHECK(part.volume() < whole.volume());
  const auto far_below = [](const Vec3& x) { return x.y + 20e-3; };
  REQUIRE_THROWS_AS(LevelSet::between(a, b, d, far_below), std::invalid_argument);
}

TEST_CASE("smoothing a label's level set rounds its staircase towards the shape it samples", "[level_set][label_image]") {
  // A ball of radius 8 voxels of 1 mm, voxelised on a lattice of 0.5 mm: the staircase deviates
  // from the sphere by up to about half a voxel diagonal.
  LabelImage image;
  const int n = 24;
  image.size = {n, n, n};
  image.labels.assign(static_cast<std::size_t>(n * n * n), 0);
  const double c = 11.5, r = 8;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        if ((i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c) <= r * r)
          image.labels[static_cast<std::size_t>(i + n * (j + n * k))] = 1;
  image.index_to_world = 1e-3 * identity3<double>();
  const double h = 0.5e-3, sigma = 1e-3;
  // RMS distance of the boundary surface's vertices from the sphere of radius r, m.
  const auto rms_off_sphere = [&](const LevelSet& level_set) {
    const SurfaceMesh surface = level_set.surface();
    double sum = 0;
    const long long count = surface.vertex_count();
    for (long long v = 0; v < count; ++v) {
      const Vec3 p{surface.vertices[3 * v], surface.vertices[3 * v + 1], surface.vertices[3 * v + 2]};
      const double off = norm(p - Vec3{c * 1e-3, c * 1e-3, c * 1e-3}) - r * 1e-3;
      sum += off * off;
    }
    return std::sqrt(sum / static_cast<double>(count));
  };
  LevelSet raw = LevelSet::from_labels(image, {1}, h, LevelSet::smoothing_band(sigma, h));
  const double rough = rms_off_sphere(raw);
  LevelSet smoothed = LevelSet::from_labels(image, {1}, h, LevelSet::smoothing_band(sigma, h));
  // sigma^2 / h^2 = 4 voxels^2: six passes of width 3 voxels, variance 6 x 2 / 3, exactly.
  CHECK(smoothed.smooth(sigma) == Approx(sigma).epsilon(1e-12));
  const double smooth = rms_off_sphere(smoothed);
  CAPTURE(rough, smooth);
  CHECK(smooth < 0.5 * rough);
  CHECK(raw.smooth(0) == 0);
  REQUIRE_THROWS_AS(raw.smooth(-1e-3), std::invalid_argument);
}
