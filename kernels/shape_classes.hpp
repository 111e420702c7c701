// Shape classes of a model's samples, for the mapped coalesced tangent pass (elasticity_phases.hpp):
// samples whose pairs have, in neighbour order, the same weights w_a and gradients that are one
// linear map of the same reference gradients,
//   w_a(s) = w_a(c),  g_a(s) = A_s r_a(c)  (a = 0 .. n_c - 1, c the class of s).
// Mesh-based samples are such: the samples at one quadrature point of one kind of element share
// N_a(xi), and g_a = J_s^-T grad_xi N_a(xi) (J_s the rest Jacobian at the sample), so against the
// class's first sample A_s = J_s^-T J_0^T. The device then reads per sample its class and A_s
// (9 values) instead of w and g per pair (4 values each): for a hexahedron sample with 8 pairs,
// 10 words instead of 32. Meshless shape functions give every sample its own weights and find
// no classes worth using.
#pragma once

#include "model/model.hpp"

#include <optional>
#include <vector>

namespace fascia::gpu {

struct ShapeClasses {
  std::vector<int> sample_class;    // [S] class of each sample
  std::vector<int> class_offsets;   // [C+1] first reference pair of each class in class_pairs
  std::vector<double> class_pairs;  // [Pc][4] per reference pair: w (dimensionless), r (3) 1/m
  std::vector<double> sample_maps;  // [S][9] A_s row-major, dimensionless
  // Largest |A_s r_a - g_a| / max_a |g_a| over all samples and pairs.
  double max_error = 0;
  int class_count() const { return static_cast<int>(class_offsets.size()) - 1; }
};

// The shape classes of the neighbour table, or nullopt where some sample fits no class within
// rel_tol (relative to its largest gradient; weights within rel_tol absolutely), a class's
// reference gradients do not span 3D, or more than max_classes classes are needed.
std::optional<ShapeClasses> find_shape_classes(const NeighbourTable& neighbours, int max_classes,
                                               double rel_tol = 1e-12);

}  // namespace fascia::gpu
