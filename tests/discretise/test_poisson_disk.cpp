// Poisson-disk sampling: inside, minimum distance, maximality, determinism.
#include "discretise/poisson_disk.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

namespace {

double min_pair_distance(const std::vector<double>& p) {
  double best = 1e300;
  const size_t n = p.size() / 3;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) best = std::min(best, norm(load3(&p[3 * i]) - load3(&p[3 * j])));
  return best;
}

}  // namespace

TEST_CASE("Poisson-disk points are inside, at least r apart, and leave no room for another", "[discretise][poisson]") {
  const SurfaceMesh surface = GENERATE(sphere_surface({0.1, 0.0, -0.05}, 0.25, 3),
                                       torus_surface({0, 0, 0}, 0.3, 0.1, 64, 24));
  const double h = 0.01, r = 0.04;
  const VoxelDomain domain(surface, h);
  const std::vector<double> points = poisson_disk_sample(domain, PoissonDiskOptions{r, 42, 30, {}});
  const int n = static_cast<int>(points.size() / 3);
  REQUIRE(n > 100);
  for (int i = 0; i < n; ++i) REQUIRE(domain.signed_distance(load3(&points[3 * i])) < 0);
  REQUIRE(min_pair_distance(points) >= r);
  // Maximality, by brute force: every voxel centre inside lies closer than r to some point.
  std::vector<CoveredVoxel> voxels;
  int interior = 0;
  for (int k = 0; k < domain.slice_count(); ++k) {
    voxels.clear();
    domain.covered_voxels(k, voxels);
    for (const CoveredVoxel& v : voxels) {
      if (v.fraction <= 0.5) continue;
      ++interior;
      double nearest = 1e300;
      for (int i = 0; i < n; ++i) nearest = std::min(nearest, norm(v.centre - load3(&points[3 * i])));
      REQUIRE(nearest < r);
    }
  }
  REQUIRE(interior > 10 * n);
  // Density: the balls of radius r/2 around the points are disjoint and lie in the object dilated
  // by r/2, so n (pi/6) r^3 <= 0.7405 (densest packing) V(dilated); the balls of radius r cover
  // the inside, so n (4/3) pi r^3 >= V.
  const double dilated = domain.volume() + surface_area(surface) * r / 2 + 4.0 / 3 * 3.14159 * std::pow(r / 2, 3);
  INFO("volume per point / r^3 = " << domain.volume() / n / (r * r * r));
  REQUIRE(n * 3.14159 / 6 * r * r * r <= 0.7405 * dilated);
  REQUIRE(n * 4.0 / 3 * 3.14159 * r * r * r >= domain.volume());
}

TEST_CASE("the same seed gives the same points; another seed other points", "[discretise][poisson]") {
  const VoxelDomain domain(box_surface({0, 0, 0}, {0.3, 0.2, 0.1}), 0.01);
  const std::vector<double> a = poisson_disk_sample(domain, PoissonDiskOptions{0.03, 7, 30, {}});
  const std::vector<double> b = poisson_disk_sample(domain, PoissonDiskOptions{0.03, 7, 30, {}});
  const std::vector<double> c = poisson_disk_sample(domain, PoissonDiskOptions{0.03, 8, 30, {}});
  REQUIRE(a == b);  // bitwise
  REQUIRE(a != c);
}

TEST_CASE("every connected component and thin sheet receives points", "[discretise][poisson]") {
  // Two disjoint boxes and a sheet three voxels thick, much thinner than r.
  SurfaceMesh s = box_surface({0, 0, 0}, {0.2, 0.2, 0.2});
  const SurfaceMesh sheet = box_surface({0.5, 0.0, 0.0}, {0.9, 0.4, 0.03});
  const int offset = s.vertex_count();
  s.vertices.insert(s.vertices.end(), sheet.vertices.begin(), sheet.vertices.end());
  for (int v : sheet.triangles) s.triangles.push_back(v + offset);
  const VoxelDomain domain(s, 0.01);
  const double r = 0.08;
  const std::vector<double> points = poisson_disk_sample(domain, PoissonDiskOptions{r, 1, 30, {}});
  int in_box = 0, in_sheet = 0;
  for (size_t i = 0; i < points.size() / 3; ++i) (points[3 * i] < 0.3 ? in_box : in_sheet)++;
  REQUIRE(in_box > 0);
  // A maximal disk set in a 0.4 x 0.4 sheet with r = 0.08: at least (0.4 / (2 r))^2 ~ 6 points.
  REQUIRE(in_sheet >= 6);
  REQUIRE(min_pair_distance(points) >= r);
}

TEST_CASE("a radius whose square overflows (r > 1.3e154 m) ends with one point", "[discretise][poisson]") {
  // Candidates are drawn in units of r: with r^2 = inf a test in metres rejects every candidate
  // and the front never ends. One point fits in a domain far smaller than r; the others fall
  // outside the grid.
  const VoxelDomain domain(box_surface({0, 0, 0}, {0.3, 0.2, 0.1}), 0.01);
  const double r = 1e155;
  REQUIRE(std::isinf(r * r));
  const std::vector<double> points = poisson_disk_sample(domain, PoissonDiskOptions{r, 7, 30, {}});
  CHECK(points.size() == 3);
}

TEST_CASE("prescribed points count as placed: r away from every point, and the set stays maximal",
          "[discretise][poisson]") {
  // A grid on the face x = 0 of a box (on the boundary, where a clamp puts its frames) and one
  // point outside it.
  const VoxelDomain domain(box_surface({0, 0, 0}, {0.3, 0.2, 0.1}), 0.01);
  const double r = 0.04;
  PoissonDiskOptions options{r, 5, 30, {}};
  for (double y = 0; y <= 0.2 + 1e-12; y += 0.05)
    for (double z = 0; z <= 0.1 + 1e-12; z += 0.05) options.prescribed.insert(options.prescribed.end(), {0.0, y, z});
  options.prescribed.insert(options.prescribed.end(), {0.35, 0.1, 0.05});
  const std::vector<double> points = poisson_disk_sample(domain, options);
  const int n = static_cast<int>(points.size() / 3), k = static_cast<int>(options.prescribed.size() / 3);
  REQUIRE(n > 20);
  REQUIRE(min_pair_distance(points) >= r);
  int near_face = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3 p = load3(&points[3 * i]);
    REQUIRE(domain.signed_distance(p) < 0);
    for (int j = 0; j < k; ++j) REQUIRE(norm(p - load3(&options.prescribed[3 * j])) >= r);
    if (p.x < 2 * r) ++near_face;
  }
  REQUIRE(near_face > 0);  // the front grows from the face
  // Maximal: every interior voxel centre lies closer than r to a point or a prescribed point.
  std::vector<double> all = points;
  all.insert(all.end(), options.prescribed.begin(), options.prescribed.end());
  std::vector<CoveredVoxel> voxels;
  for (int s = 0; s < domain.slice_count(); ++s) {
    voxels.clear();
    domain.covered_voxels(s, voxels);
    for (const CoveredVoxel& v : voxels) {
      if (v.fraction <= 0.5) continue;
      double nearest = 1e300;
      for (size_t i = 0; i < all.size() / 3; ++i) nearest = std::min(nearest, norm(v.centre - load3(&all[3 * i])));
      REQUIRE(nearest < r);
    }
  }
}
