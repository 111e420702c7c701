// External loads as potentials on the frame configuration: gravity acting on every sample's
// mass through eq. (3), and point forces on frames. Conservative, so static equilibrium is the
// minimum of W + V and the line search works on one energy.
#pragma once

#include "core/small_math.hpp"
#include "model/model.hpp"
#include "model/state.hpp"

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

// V = -scale (sum_s rho_s v_s g . p_s + sum_i m_i g . x_i + sum_k f_k . x_k + sum_m f_m . p_m), J,
// with m_i the frames' point masses (Model::frame_point_masses: shell nodes, rigid bodies).
double load_potential(const Model& model, const ExternalLoads& loads, const State& state);

// Adds dV/d(theta) at theta = 0 to gradient [N][6].
void add_load_gradient(const Model& model, const ExternalLoads& loads, const State& state, double* gradient);

// Adds the rotational blocks of the Hessian of V (the gravity moment arm a = R l turns with the
// frame) to blocks [N][9].
void add_load_rotational_blocks(const Model& model, const ExternalLoads& loads, const State& state, double* blocks);

// Total external force on translations (N), for convergence scales.
double load_force_norm(const Model& model, const ExternalLoads& loads);

}  // namespace fascia
