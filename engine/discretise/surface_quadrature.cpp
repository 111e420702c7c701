#include "discretise/surface_quadrature.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace fascia {

namespace {

// Emits the rule of triangle (a, b, c) or bisects it through the midpoint of
// its longest edge; the halves keep the orientation. Depth is bounded by the
// edge ratio (each level halves an edge).
void refine(const Vec3 &a, const Vec3 &b, const Vec3 &c, double spacing,
            SurfaceQuadrature &q) {
  const double ab = norm(b - a), bc = norm(c - b), ca = norm(a - c);
  if (std::max({ab, bc, ca}) <= spacing) {
    const Vec3 normal = (1.0 / 6.0) * cross(b - a, c - a); // area vector / 3
    for (const Vec3 *major : {&a, &b, &c}) {
      const Vec3 x = (2.0 / 3.0) * *major + (1.0 / 6.0) * (a + b + c - *major);
      q.points.insert(q.points.end(), {x.x, x.y, x.z});
      q.normals.insert(q.normals.end(), {normal.x, normal.y, normal.z});
    }
    return;
  }
  if (ab >= bc && ab >= ca) {
    const Vec3 m = 0.5 * (a + b);
    refine(a, m, c, spacing, q), refine(m, b, c, spacing, q);
  } else if (bc >= ca) {
    const Vec3 m = 0.5 * (b + c);
    refine(a, b, m, spacing, q), refine(a, m, c, spacing, q);
  } else {
    const Vec3 m = 0.5 * (c + a);
    refine(a, b, m, spacing, q), refine(m, b, c, spacing, q);
  }
}

} // namespace

SurfaceQuadrature surface_quadrature(const SurfaceMesh &mesh, double spacing) {
  if (!(spacing > 0))
    throw std::invalid_argument("surface quadrature: spacing must be positive");
  SurfaceQuadrature q;
  for (int t = 0; t < mesh.triangle_count(); ++t)
    refine(load3(&mesh.vertices[3 * mesh.triangles[3 * t]]),
           load3(&mesh.vertices[3 * mesh.triangles[3 * t + 1]]),
           load3(&mesh.vertices[3 * mesh.triangles[3 * t + 2]]), spacing, q);
  return q;
}

} // namespace fascia
