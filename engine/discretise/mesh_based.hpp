// Mesh-based discretisation (paper §2.1): frames at the mesh vertices, samples at quadrature
// points of each element, weights and gradients from the element's shape functions.
#pragma once

#include "discretise/volume_mesh.hpp"
#include "model/model.hpp"

namespace fascia {

struct MeshDiscretisation {
  // Tetrahedra: 1 or 4 samples per element; hexahedra: 1, 2 or 3 per axis (1, 8 or 27).
  int quadrature = 0;  // 0 = default: 4 per tetrahedron, 2 per axis for hexahedra
};

// Builds frames, samples, neighbour and reverse tables, frame masses; all frames free.
// Throws std::invalid_argument on degenerate or inverted elements.
Model build_mesh_model(const VolumeMesh& mesh, const Material& material, const MeshDiscretisation& options = {});

}  // namespace fascia
