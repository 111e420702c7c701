// Surface quadrature: the divergence identities the consistent integration
// relies on, exactly.
#include "discretise/surface_quadrature.hpp"

#include <catch2/catch.hpp>

using namespace fascia;

TEST_CASE("surface quadrature integrates linear and quadratic fields exactly "
          "on closed surfaces",
          "[discretise][meshless][patch]") {
  // A long box (the beam's thin triangles) and a sphere (curved, tilted
  // triangles).
  const SurfaceMesh mesh = GENERATE(box_surface({0.5, -1, 2}, {16.5, 0, 3}),
                                    sphere_surface({0.3, 0.2, -0.1}, 0.7, 2));
  const double spacing = 0.2;
  const SurfaceQuadrature q = surface_quadrature(mesh, spacing);
  const double V = surface_volume(mesh);
  // Enclosed first moment, by the divergence theorem on x_m^2 / 2 with the
  // 3-point rule on each original triangle (degree 2: exact), independent of
  // the refinement under test.
  const SurfaceQuadrature coarse = surface_quadrature(mesh, 1e9);
  Vec3 first{0, 0, 0};
  for (size_t k = 0; k < coarse.points.size() / 3; ++k) {
    const Vec3 b = load3(&coarse.points[3 * k]),
               a = load3(&coarse.normals[3 * k]);
    first += Vec3{0.5 * b.x * b.x * a.x, 0.5 * b.y * b.y * a.y,
                  0.5 * b.z * b.z * a.z};
  }
  Vec3 sum_a{0, 0, 0}, moment{0, 0, 0};
  Mat3 sum_ba = zero3();
  double area = 0;
  for (size_t k = 0; k < q.points.size() / 3; ++k) {
    const Vec3 b = load3(&q.points[3 * k]), a = load3(&q.normals[3 * k]);
    sum_a += a, sum_ba += outer(b, a), area += norm(a);
    moment += Vec3{0.5 * b.x * b.x * a.x, 0.5 * b.y * b.y * a.y,
                   0.5 * b.z * b.z * a.z};
  }
  // Round-off of ~1e4 terms of size |a| ~ spacing^2 / 6 and |b a| ~ 16 |a|:
  // 1e-12 relative.
  REQUIRE(norm(sum_a) <= 1e-12 * area);
  REQUIRE(std::sqrt(ddot(sum_ba - V * identity3(), sum_ba - V * identity3())) <=
          1e-12 * 16 * area);
  REQUIRE(norm(moment - first) <= 1e-11 * 16 * 16 * area);
  REQUIRE(area == Approx(surface_area(mesh)).epsilon(1e-12));
  // Pieces no longer than the spacing, but not much smaller: a piece with every
  // edge <= s has area <= 0.43 s^2, and bisection stops at the first such
  // piece, so the count stays a modest multiple of area / s^2 (measured 12.3 on
  // the long box, whose 16 x 1 triangles are skinny).
  INFO("pieces per area / spacing^2: " << (q.points.size() / 9) * spacing *
                                              spacing / surface_area(mesh));
  REQUIRE(q.points.size() / 9 <=
          static_cast<size_t>(16 * surface_area(mesh) / (spacing * spacing)));
}
