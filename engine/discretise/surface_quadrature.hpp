// Quadrature on a closed triangle surface, for the boundary integrals of
// consistent meshless integration (shape/consistent_integration.hpp): each
// triangle is bisected through the midpoint of its longest edge until no edge
// exceeds the spacing (long thin triangles of CAD boxes become pieces of about
// spacing^2 / 2), and each piece carries the 3-point rule of degree 2 (points
// at barycentric (2/3, 1/6, 1/6) and permutations, weights area / 3).
//
// On a closed, outward-oriented surface the rule integrates linear functions
// exactly, so sum_q a_q = 0 and sum_q b_q a_q^T = V I (V the enclosed volume,
// a_q the weighted normals), the identities the consistency constraints rely
// on.
#pragma once

#include "discretise/surface_mesh.hpp"

#include <vector>

namespace fascia {

struct SurfaceQuadrature {
  std::vector<double> points; // [Q][3] m
  std::vector<double>
      normals; // [Q][3] unit outward normal times the weight, m^2
};

// @param spacing largest sub-triangle edge (m), > 0.
SurfaceQuadrature surface_quadrature(const SurfaceMesh &mesh, double spacing);

} // namespace fascia
