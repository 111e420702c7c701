// Mesh-based shape functions: linear tetrahedra (4 frames per sample) and trilinear hexahedra
// (8 frames per sample). Both are partitions of unity with linear precision, so F = I at rest
// and an affine frame field is reproduced exactly (patch test).
#pragma once

#include "core/small_math.hpp"

#include <array>

namespace fascia {

template <int K>
struct ElementShape {
  std::array<double, K> weights;    // w_a(xi)
  std::array<Vec3, K> gradients;    // grad_X w_a, 1/m
  double jacobian_determinant;      // det(dX/dxi); the sample volume is |det| * quadrature weight
};

// Linear tetrahedron with vertices X[0..3] at reference point xi (barycentric
// (1 - xi1 - xi2 - xi3, xi1, xi2, xi3)). Precondition: non-degenerate (det != 0).
ElementShape<4> tet_linear_shape(const std::array<Vec3, 4>& X, const std::array<double, 3>& xi);

// Trilinear hexahedron, VTK node order ((0,0,0),(1,0,0),(1,1,0),(0,1,0),(0,0,1),(1,0,1),(1,1,1),
// (0,1,1) in the corners of [-1,1]^3), at reference point xi in [-1,1]^3.
ElementShape<8> hex_trilinear_shape(const std::array<Vec3, 8>& X, const std::array<double, 3>& xi);

// dX/dxi of the trilinear map at xi (3x3, column c = dX/dxi_c).
Mat3 hex_trilinear_jacobian(const std::array<Vec3, 8>& X, const std::array<double, 3>& xi);

}  // namespace fascia
