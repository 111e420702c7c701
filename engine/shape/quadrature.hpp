// Quadrature rules that place the samples inside mesh elements (paper §2.1: "the samples are
// placed inside the elements of the mesh using barycentric coordinates").
#pragma once

#include <array>
#include <vector>

namespace fascia {

struct QuadraturePoint {
  std::array<double, 3> xi;  // reference coordinates
  double weight;             // sums to the reference element volume
};

// Tetrahedron, reference coordinates (xi1, xi2, xi3) of vertices 1..3 (vertex 0 at the origin),
// reference volume 1/6. points: 1 (centroid, exact for degree 1) or 4 (exact for degree 2).
std::vector<QuadraturePoint> tet_quadrature(int points);

// Hexahedron on [-1, 1]^3, tensor Gauss-Legendre with n = 1, 2 or 3 points per axis
// (exact for degree 2n - 1 per axis); weights sum to 8.
std::vector<QuadraturePoint> hex_quadrature(int points_per_axis);

}  // namespace fascia
