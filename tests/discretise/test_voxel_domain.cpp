// Voxelised volumes against analytic values, and sample volumes that partition them.
#include "discretise/poisson_disk.hpp"
#include "discretise/sample_volumes.hpp"
#include "discretise/voxel_domain.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Shape {
  const char* name;
  SurfaceMesh surface;
  double exact;         // analytic volume of the smooth shape, m^3
  double convex_edges;  // total length of sharp convex edges, m
};

}  // namespace

TEST_CASE("voxelised volumes of a sphere, a box and a torus match the analytic values", "[discretise][voxel]") {
  // Shapes off the voxel lattice (odd offsets) so that no face falls on voxel centres by luck.
  const Shape shape = GENERATE(Shape{"sphere", sphere_surface({0.01, 0.02, 0.03}, 0.5, 5), 4.0 / 3 * kPi * 0.125, 0},
                               Shape{"box", box_surface({0.013, -0.007, 0.021}, {1.013, 0.593, 0.421}), 0.6 * 0.4, 8.0},
                               Shape{"torus", torus_surface({0.003, 0.011, -0.02}, 0.5, 0.2, 256, 96),
                                     2 * kPi * kPi * 0.5 * 0.2 * 0.2, 0});
  const double h = 0.03;
  const VoxelDomain domain(shape.surface, h);
  const double v = domain.volume();
  const double area = surface_area(shape.surface);
  // Tolerance. (1) The triangulation itself differs from the smooth shape by
  // |V_mesh - V_exact| (inscribed polyhedra: 5e-4 relative for the sphere and the torus here, 0
  // for the box). (2) A binary voxelisation can be off by up to about area * h / 2 (every voxel the
  // surface cuts misclassified the same way). The coverage ramp clamp(1/2 - phi/h, 0, 1) is exact
  // for face-parallel planes and unbiased for tilted ones; what remains comes from curvature,
  // edges and corners (O(h^2)). We require 25 times better than the binary bound: 0.02 area h,
  // i.e. 0.5 % of the volume at this resolution; measured 0.0007 to 0.004 area h. (3) Sharp
  // convex edges: the ramp rounds them, adding volume ~ c h^2 per unit edge length (c = pi/96 from
  // the outer quarter-cylinder alone; 0.13 measured on small boxes); we allow 0.25 h^2 per metre.
  const double tessellation = std::abs(surface_volume(shape.surface) - shape.exact);
  const auto edges = [&](double hh) { return 0.25 * hh * hh * shape.convex_edges; };
  INFO(shape.name << ": voxel volume " << v << ", analytic " << shape.exact << ", mesh " << surface_volume(shape.surface)
                  << ", error / (area h) " << (v - shape.exact) / (area * h));
  REQUIRE(std::abs(v - shape.exact) <= tessellation + 0.02 * area * h + edges(h));
  // The same at half the voxel size: the error must not grow (convergence, not luck).
  const VoxelDomain fine(shape.surface, h / 2);
  REQUIRE(std::abs(fine.volume() - shape.exact) <= tessellation + 0.02 * area * h / 2 + edges(h / 2));
}

TEST_CASE("sample volumes partition the voxelised volume", "[discretise][voxel]") {
  const SurfaceMesh surface = sphere_surface({0.0, 0.0, 0.0}, 0.3, 4);
  const VoxelDomain domain(surface, 0.02);
  const double r = 0.05;
  const std::vector<double> samples = poisson_disk_sample(domain, PoissonDiskOptions{r, 3, 30, {}});
  const SampleVolumes sv = sample_volumes(domain, samples, r);
  REQUIRE(sv.volumes.size() == samples.size() / 3);
  REQUIRE(sv.unassigned == 0);
  // Same voxels summed in a different order: round-off only.
  REQUIRE(sv.assigned == Approx(domain.volume()).epsilon(1e-12));
  double smallest = 1e300, largest = 0;
  for (double v : sv.volumes) smallest = std::min(smallest, v), largest = std::max(largest, v);
  REQUIRE(smallest > 0);
  // Voronoi cells of a maximal Poisson-disk set (radius r) hold a ball of radius r/2 and lie in
  // a ball of radius r: every volume is below 4/3 pi r^3 (plus a voxel of slack).
  REQUIRE(largest <= 4.0 / 3 * kPi * r * r * r + std::pow(0.02, 3));
}
