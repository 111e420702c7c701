// Volume meshes for the mesh-based discretisation: tetrahedra or hexahedra.
#pragma once

#include "core/small_math.hpp"

#include <vector>

namespace fascia {

enum class CellType { tetrahedron = 4, hexahedron = 8 };

struct VolumeMesh {
  std::vector<double> vertices;  // [V][3] m
  std::vector<int> cells;        // [C][k], k = 4 (tet) or 8 (hex, VTK order)
  CellType type = CellType::hexahedron;

  int nodes_per_cell() const { return static_cast<int>(type); }
  int vertex_count() const { return static_cast<int>(vertices.size() / 3); }
  int cell_count() const { return static_cast<int>(cells.size()) / nodes_per_cell(); }
};

// Regular grid of nx * ny * nz hexahedra over the box [lo, hi].
VolumeMesh box_hex_mesh(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz);

// The same grid with each hexahedron split into 6 tetrahedra along its main diagonal (Kuhn
// split; conforming between neighbouring cells).
VolumeMesh box_tet_mesh(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz);

}  // namespace fascia
