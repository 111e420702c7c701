// Reading volume meshes for the mesh-based discretisation.
//   .vtk  legacy VTK, ASCII, DATASET UNSTRUCTURED_GRID with VTK_TETRA (10) or VTK_HEXAHEDRON (12)
//   .msh  Gmsh 2.2 ASCII, elements of type 4 (4-node tetrahedron) or 5 (8-node hexahedron)
// One cell type per mesh; other cells (surface triangles, lines, points) are ignored. Coordinates
// are taken as metres.
#pragma once

#include "discretise/volume_mesh.hpp"

#include <stdexcept>
#include <string>

namespace fascia {

// A file that exists but cannot be parsed. what() is "path:line: message".
class MeshFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws std::ios_base::failure when the file cannot be opened, MeshFormatError when its content
// is not a supported mesh.
VolumeMesh read_volume_mesh(const std::string& path);

// Writes legacy VTK ASCII (tests, and to hand a generated box to other tools).
void write_vtk_volume_mesh(const std::string& path, const VolumeMesh& mesh);

}  // namespace fascia
