// Shell test fixtures: structured triangle meshes of rectangles and cylinder patches.
#pragma once

#include "discretise/surface_mesh.hpp"
#include "model/assembly.hpp"

#include <cmath>

namespace fascia::test {

// nx x ny cells on [0, a] x [0, b] at z = 0, each cell split along alternating diagonals
// (a symmetric pattern, so a centred load gives a symmetric answer up to the pattern).
inline SurfaceMesh rectangle_surface(double a, double b, int nx, int ny) {
  SurfaceMesh m;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) m.vertices.insert(m.vertices.end(), {a * i / nx, b * j / ny, 0.0});
  auto v = [nx](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const bool flip = (i + j) % 2 == 1;
      if (!flip) {
        m.triangles.insert(m.triangles.end(), {v(i, j), v(i + 1, j), v(i + 1, j + 1)});
        m.triangles.insert(m.triangles.end(), {v(i, j), v(i + 1, j + 1), v(i, j + 1)});
      } else {
        m.triangles.insert(m.triangles.end(), {v(i, j), v(i + 1, j), v(i, j + 1)});
        m.triangles.insert(m.triangles.end(), {v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)});
      }
    }
  return m;
}

// The rectangle bent onto a cylinder of radius r about the y axis (a curved rest shape).
inline SurfaceMesh cylinder_patch(double a, double b, int nx, int ny, double r) {
  SurfaceMesh m = rectangle_surface(a, b, nx, ny);
  for (int k = 0; k < m.vertex_count(); ++k) {
    const double x = m.vertices[3 * k], phi = x / r;
    m.vertices[3 * k] = r * std::sin(phi);
    m.vertices[3 * k + 2] = r * (1 - std::cos(phi));
  }
  return m;
}

inline Model shell_model(const SurfaceMesh& mesh, const ShellProperties& p) {
  ModelBuilder builder;
  builder.add_shell("shell", mesh, p);
  return builder.build();
}

}  // namespace fascia::test
