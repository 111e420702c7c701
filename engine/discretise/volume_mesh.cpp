#include "discretise/volume_mesh.hpp"

#include <stdexcept>

namespace fascia {

VolumeMesh box_hex_mesh(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz) {
  if (nx < 1 || ny < 1 || nz < 1) throw std::invalid_argument("box mesh: resolution must be >= 1 per axis");
  VolumeMesh mesh;
  mesh.type = CellType::hexahedron;
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        mesh.vertices.push_back(lo.x + (hi.x - lo.x) * i / nx);
        mesh.vertices.push_back(lo.y + (hi.y - lo.y) * j / ny);
        mesh.vertices.push_back(lo.z + (hi.z - lo.z) * k / nz);
      }
  auto id = [&](int i, int j, int k) { return i + (nx + 1) * (j + (ny + 1) * k); };
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        const int c[8] = {id(i, j, k),         id(i + 1, j, k),         id(i + 1, j + 1, k),
                          id(i, j + 1, k),     id(i, j, k + 1),         id(i + 1, j, k + 1),
                          id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)};
        mesh.cells.insert(mesh.cells.end(), c, c + 8);
      }
  return mesh;
}

VolumeMesh box_tet_mesh(const Vec3& lo, const Vec3& hi, int nx, int ny, int nz) {
  VolumeMesh hex = box_hex_mesh(lo, hi, nx, ny, nz);
  VolumeMesh mesh;
  mesh.type = CellType::tetrahedron;
  mesh.vertices = hex.vertices;
  // Kuhn split of the cube along the diagonal 0-6: six positively oriented tetrahedra.
  static const int split[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                  {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
  for (int c = 0; c < hex.cell_count(); ++c) {
    const int* h = &hex.cells[8 * c];
    for (const auto& t : split)
      for (int a = 0; a < 4; ++a) mesh.cells.push_back(h[t[a]]);
  }
  return mesh;
}

}  // namespace fascia
