// Mass, centre of mass and inertia of a homogeneous solid bounded by a closed, outward-oriented
// triangle mesh (a rigid body, paper §4.2), by the divergence theorem: the solid is the signed
// sum of the tetrahedra (0, a, b, c) over the triangles, with for each
//   V = a . (b x c) / 6,  int x dV = V (a + b + c) / 4,
//   int x x^T dV = V/20 (a a^T + b b^T + c c^T + s s^T),  s = a + b + c,
// exact for the triangulated solid.
#pragma once

#include "core/small_math.hpp"
#include "discretise/surface_mesh.hpp"

namespace fascia {

struct MassProperties {
  double volume = 0;  // m^3
  double mass = 0;    // kg
  Vec3 centre{0, 0, 0};  // m
  Mat3 inertia = zero3();  // kg m^2, about the centre of mass, world axes
};

// @pre density > 0 and the mesh is closed and outward oriented (volume > 0, else throws
// std::invalid_argument).
MassProperties mass_properties(const SurfaceMesh& mesh, double density);

}  // namespace fascia
