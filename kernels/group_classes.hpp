// Classes of the grouped pass's groups (group_layout.hpp), for its mapped form: groups whose
// tables of pairs, thread by thread and frame by frame, have the same weights and gradients that
// are one linear map of the same reference gradients,
//   w(l, k) = w_c(l, k),  g(l, k) = A_g r_c(l, k)   (thread l, frame k, c the class of group g).
// The samples of an element whose Jacobian is constant (tetrahedra, parallelepiped hexahedra)
// are such: g = J^-T grad_xi N(xi), so against the class's first group A_g = J_g^-T J_0^T, the
// same for all its samples. The device then reads per group its class and A_g (10 values) instead
// of w and g per pair (4 values each): for a hexahedron's 8 samples of 8 pairs, 10 words instead
// of 256. find_shape_classes (shape_classes.hpp) does the same per sample.
#pragma once

#include "group_layout.hpp"
#include "model/model.hpp"

#include <optional>
#include <string>
#include <vector>

namespace fascia::gpu {

struct GroupClasses {
  std::vector<int> group_class;     // [G] class of each group
  // [C][kGroupLanes][kGroupLanes][4] per class, thread l and frame k: w (dimensionless), r (3) 1/m;
  // 0 where the class's groups have no such pair.
  std::vector<double> class_pairs;
  std::vector<double> group_maps;   // [G][9] A_g row-major, dimensionless
  // Largest |A_g r - g| / max |g| over the groups and their pairs.
  double max_error = 0;
  int class_count() const { return static_cast<int>(class_pairs.size()) / (4 * kGroupLanes * kGroupLanes); }
};

// The classes of the groups of a model in group order, or nullopt with the reason in `refusal`
// where a group fits no class within rel_tol (relative to its largest gradient; weights within
// rel_tol absolutely), a class's reference gradients do not span 3D, or more than max_classes
// classes are needed.
std::optional<GroupClasses> find_group_classes(const Model& model, const GroupLayout& layout, int max_classes,
                                               std::string* refusal = nullptr, double rel_tol = 1e-12);

}  // namespace fascia::gpu
