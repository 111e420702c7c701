// External loads on the frame configuration: gravity acting on every sample's mass through
// eq. (3) and on the frames' point masses (Model::frame_point_masses: shell nodes, rigid bodies),
// point forces on frames, and forces on material points. All are constant forces, so they have a
// potential V = -scale (sum_s rho_s v_s g . p_s + sum_i m_i g . x_i + sum_k f_k . x_k +
// sum_m f_m . p_m) (J): static equilibrium is the minimum of W + V and the line search works on
// one energy. mechanics/frame_loads.hpp sums V per frame and evaluates it.
#pragma once

#include "core/small_math.hpp"

#include <vector>

namespace fascia {

struct PointForce {
  int frame;
  Vec3 force;  // N, world axes, constant
};

// A constant force on a material point p = sum_k w_k (x_k + R_k l_k) (eq. 3): the consistent
// discrete form of a surface traction (one per surface quadrature point, force = t dA). Unlike a
// point force on a frame it also loads the frames' rotations through the moment arm R_k l_k.
struct MaterialPointForce {
  std::vector<int> frames;
  std::vector<double> weights;
  std::vector<double> rest_offsets;  // [k][3] m
  Vec3 force{0, 0, 0};               // N
};

struct ExternalLoads {
  Vec3 gravity{0, 0, 0};  // m/s^2
  std::vector<PointForce> point_forces;
  std::vector<MaterialPointForce> material_point_forces;
  double scale = 1.0;  // load factor (load stepping)
};

}  // namespace fascia
