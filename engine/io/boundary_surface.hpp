// The boundary surface of a volume mesh: faces that belong to exactly one cell, oriented outwards.
// Written to the trajectory (with connectivity) so ParaView shows the deformed object, and used
// for surface tractions.
#pragma once

#include "discretise/volume_mesh.hpp"

#include <vector>

namespace fascia {

struct BoundarySurface {
  int nodes_per_face = 3;          // 3 (triangles, from tetrahedra) or 4 (quads, from hexahedra)
  std::vector<int> faces;          // [F][nodes_per_face], indices into vertices
  std::vector<int> vertices;       // [V] mesh vertex (= frame, mesh-based) of each surface vertex

  int face_count() const { return static_cast<int>(faces.size()) / nodes_per_face; }
  int vertex_count() const { return static_cast<int>(vertices.size()); }
};

// Faces of the mesh not shared by two cells, with outward orientation (counter-clockwise seen from
// outside); vertices renumbered compactly in order of first use.
BoundarySurface boundary_surface(const VolumeMesh& mesh);

}  // namespace fascia
