#include "io/boundary_surface.hpp"

#include <utility>
#include <array>
#include <map>

namespace fascia {

namespace {

// Local faces of the reference cells, outward (counter-clockwise seen from outside) for a
// positively oriented cell. Tetrahedron (0,1,2,3); hexahedron in VTK order.
const std::vector<std::vector<int>>& local_faces(CellType type) {
  static const std::vector<std::vector<int>> tet = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  static const std::vector<std::vector<int>> hex = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                                    {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  return type == CellType::tetrahedron ? tet : hex;
}

}  // namespace

BoundarySurface boundary_surface(const VolumeMesh& mesh) {
  const int k = mesh.nodes_per_cell();
  const auto& faces = local_faces(mesh.type);
  const int fn = static_cast<int>(faces.front().size());
  // Key: sorted vertex ids; value: (count, one oriented instance).
  std::map<std::array<int, 4>, std::pair<int, std::array<int, 4>>> seen;
  std::vector<std::array<int, 4>> order;
  for (int c = 0; c < mesh.cell_count(); ++c) {
    const int* cell = &mesh.cells[static_cast<std::size_t>(c * k)];
    for (const auto& f : faces) {
      std::array<int, 4> oriented{-1, -1, -1, -1};
      for (int j = 0; j < fn; ++j) oriented[static_cast<std::size_t>(j)] = cell[f[static_cast<std::size_t>(j)]];
      std::array<int, 4> key = oriented;
      // Insertion sort of the fn <= 4 ids (std::sort trips a GCC 12 -Warray-bounds false positive).
      for (int a = 1; a < fn; ++a)
        for (int b = a; b > 0 && key[static_cast<std::size_t>(b - 1)] > key[static_cast<std::size_t>(b)]; --b)
          std::swap(key[static_cast<std::size_t>(b - 1)], key[static_cast<std::size_t>(b)]);
      auto [it, inserted] = seen.try_emplace(key, 0, oriented);
      if (inserted) order.push_back(key);
      ++it->second.first;
    }
  }
  BoundarySurface out;
  out.nodes_per_face = fn;
  std::vector<int> renumber(static_cast<std::size_t>(mesh.vertex_count()), -1);
  for (const auto& key : order) {
    const auto& [count, oriented] = seen[key];
    if (count != 1) continue;
    for (int j = 0; j < fn; ++j) {
      const int v = oriented[static_cast<std::size_t>(j)];
      if (renumber[static_cast<std::size_t>(v)] < 0) {
        renumber[static_cast<std::size_t>(v)] = out.vertex_count();
        out.vertices.push_back(v);
      }
      out.faces.push_back(renumber[static_cast<std::size_t>(v)]);
    }
  }
  return out;
}

}  // namespace fascia
