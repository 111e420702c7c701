// Closed triangle surface meshes: the geometric domain of a meshless tissue (paper §2.1, "a
// boundary surface mesh is used to provide the geometrical domain of the tissues").
//
// Files come from segmentation tools (STL ASCII/binary, OBJ, PLY, OFF) and are read with assimp;
// coincident vertices are welded by exact position (STL stores three vertices per facet).
#pragma once

#include "core/small_math.hpp"

#include <string>
#include <vector>

namespace fascia {

struct SurfaceMesh {
  std::vector<double> vertices;  // [V][3] m
  std::vector<int> triangles;    // [T][3] vertex indices

  int vertex_count() const { return static_cast<int>(vertices.size() / 3); }
  int triangle_count() const { return static_cast<int>(triangles.size() / 3); }
};

// Applied to file coordinates c as x = rotation * (scale * c) + translation. `scale` converts the
// file's unit to metres (0.001 for millimetres, the usual unit of segmentation tools).
struct SurfaceImport {
  double scale = 1.0;
  Mat3 rotation = identity3();
  Vec3 translation{0, 0, 0};
};

// Reads every mesh of the file (polygons triangulated, node transforms applied) and welds
// coincident vertices. Throws std::runtime_error naming the file when it cannot be read or holds
// no triangle. Does not check closedness: see check_surface().
SurfaceMesh read_surface_mesh(const std::string& path, const SurfaceImport& import = {});

// Topological and geometric defects that make a surface unusable as a tissue boundary.
struct SurfaceDefects {
  int boundary_edges = 0;        // edges used by one triangle: the surface has holes
  int non_manifold_edges = 0;    // edges used by three or more triangles
  int inconsistent_edges = 0;    // edges traversed twice in the same direction (flipped faces)
  int degenerate_triangles = 0;  // zero area (relative to the bounding box)
  int intersecting_pairs = 0;    // pairs of triangles without a shared vertex that cross
  Vec3 first_defect{0, 0, 0};    // a point on the first defect found (m), for messages

  bool closed() const { return boundary_edges == 0 && non_manifold_edges == 0; }
  bool ok() const { return closed() && inconsistent_edges == 0 && intersecting_pairs == 0; }
  // One line per kind of defect, naming a location; empty when ok().
  std::string describe() const;
};

// Edge topology in O(T log T); self-intersections with a uniform grid broad phase and exact
// segment-triangle tests between triangles that share no vertex. Coplanar overlaps and crossings
// of triangles that share a vertex are not reported.
SurfaceDefects check_surface(const SurfaceMesh& mesh);

// Enclosed volume by the divergence theorem, m^3 (positive for outward-oriented triangles).
double surface_volume(const SurfaceMesh& mesh);
double surface_area(const SurfaceMesh& mesh);
void surface_bounds(const SurfaceMesh& mesh, Vec3& lo, Vec3& hi);

// Closed, outward-oriented test and benchmark surfaces.
// Box [lo, hi] with n[k] subdivisions per axis on each face.
SurfaceMesh box_surface(const Vec3& lo, const Vec3& hi, int nx = 1, int ny = 1, int nz = 1);
// Sphere from an icosahedron subdivided `subdivisions` times (20 * 4^s triangles).
SurfaceMesh sphere_surface(const Vec3& centre, double radius, int subdivisions);
// Torus around the z axis: major radius R (centre to tube centre), minor radius r (tube).
SurfaceMesh torus_surface(const Vec3& centre, double major_radius, double minor_radius, int major_segments,
                          int minor_segments);

}  // namespace fascia
