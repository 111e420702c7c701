#include "io/boundary_surface.hpp"

#include <catch2/catch.hpp>

using namespace fascia;

namespace {

// Volume enclosed by the surface (divergence theorem), positive when faces point outwards.
double enclosed_volume(const VolumeMesh& mesh, const BoundarySurface& s) {
  double volume = 0;
  const int k = s.nodes_per_face;
  for (int f = 0; f < s.face_count(); ++f) {
    auto p = [&](int j) {
      const int v = s.vertices[static_cast<std::size_t>(s.faces[static_cast<std::size_t>(f * k + j)])];
      return Vec3{mesh.vertices[3 * v], mesh.vertices[3 * v + 1], mesh.vertices[3 * v + 2]};
    };
    // Fan triangulation from the first vertex; signed tetrahedron volumes with the origin.
    for (int j = 1; j + 1 < k; ++j) volume += dot(p(0), cross(p(j), p(j + 1))) / 6.0;
  }
  return volume;
}

}  // namespace

TEST_CASE("boundary of a hexahedral grid: outward quads", "[io]") {
  const VolumeMesh mesh = box_hex_mesh({0, 0, 0}, {2, 1, 1}, 2, 2, 2);
  const BoundarySurface s = boundary_surface(mesh);
  CHECK(s.nodes_per_face == 4);
  CHECK(s.face_count() == 6 * 4);
  CHECK(s.vertex_count() == 27 - 1);  // every vertex but the centre
  CHECK(enclosed_volume(mesh, s) == Approx(2.0));
}

TEST_CASE("boundary of a tetrahedral grid: outward triangles", "[io]") {
  const VolumeMesh mesh = box_tet_mesh({0, 0, 0}, {1, 2, 3}, 2, 2, 2);
  const BoundarySurface s = boundary_surface(mesh);
  CHECK(s.nodes_per_face == 3);
  CHECK(s.face_count() == 6 * 4 * 2);
  CHECK(enclosed_volume(mesh, s) == Approx(6.0));
}
