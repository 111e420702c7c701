// Variationally consistent sample integration for meshless frames (after Chen,
// Hillman & Rüter, "An arbitrary order variationally consistent integration for
// Galerkin meshfree methods", IJNME 2013), in a symmetric (Bubnov-Galerkin)
// form that keeps the energy W = sum_s v_s psi(F_s).
//
// The frame method needs, for each frame i, the divergence theorem on its shape
// function w_i and on the field w_i (x - x_i) (the lever of its rotation, eq. 8
// and 10), computed with the samples:
//   (a) sum_s v_s grad w_is                              = int_boundary w_i N
//   dA (b) sum_s v_s [(p_s - x_i) grad w_is^T + w_is I]     = int_boundary w_i
//   (x - x_i) N^T dA
// Then a constant stress is in equilibrium with its boundary traction for every
// frame, free boundaries included (the Galerkin patch test), translations and
// rotations alike. A sample rule with voxel volumes satisfies (a) and (b) only
// approximately, so the stored gradients are corrected, grad w_is + c_is, with
// the smallest sum_(s,i) |c_is|^2 such that
//   (a) and (b) hold exactly (4 x 3 equations per frame), and
//   sum_i c_is = 0 and sum_i (x_i - p_s) c_is^T = 0 at every sample (4 x 3
//   equations),
// the last two keeping partition of unity and linear precision of the gradients
// at each sample (sum_i grad w_is = 0, sum_i x_i grad w_is^T = I), hence F = I
// at rest, rigid-motion invariance and F = A for affinely moved frames. The
// weights w_is are not changed.
//
// Solution. Per gradient component, the sample equations are eliminated exactly
// (a 4 x 4 projection per sample) and the frame multipliers lambda ([N][4])
// solve the semi-definite system H lambda = t, H = sum_s v_s^2 E_s Pi_s E_s^T,
// by conjugate gradients (solve/pcg.hpp) preconditioned by a sparse Cholesky
// factorisation of H + 1e-8 diag(H) whose results are projected off the null
// space: about ten iterations per component at any resolution. H has sixteen
// null vectors per component: the sample equations imply identities between
// frame equations (sum_i (a)_i, sum_i x_i (a)_i^T, sum_i (b)_i, and sum_i
// [x_i^T M x_i (a)_i + (M x_i)^T (b)_i] for every 3 x 3 M). The targets satisfy
// them when the boundary rule integrates linear and quadratic functions exactly
// and the sample rule integrates 1 and x exactly: the volumes are fitted to the
// enclosed volume and first moment (a linear scaling, below), and t is
// projected off the null space (round-off only).
#pragma once

#include "model/model.hpp"
#include "shape/meshless_shape.hpp"

#include <vector>

namespace fascia {

struct ConsistentIntegrationReport {
  int iterations =
      0; // conjugate-gradient iterations, summed over the 3 components
  double initial_defect =
      0; // max over frames of |(a)|, |(b)| / rho_i before, relative (see below)
  double defect = 0; // the same after correction
};

// Corrects samples.weight_gradients in place.
// @param samples  the samples' table over shape.frames (build_meshless_table)
// @param volumes  [S] m^3, the sample volumes v_s; scaled by 1 + a + b . (p_s -
// p_mean) so that
//                 they integrate 1 and x exactly (the volume and first moment
//                 of the surface)
// @param sample_points [S][3] m
// @param boundary_points [Q][3] m, the surface quadrature points
// @param boundary the table at the boundary quadrature points over the same
// frames (weights and
//                 rest offsets b_q - x_i are used)
// @param boundary_normals [Q][3] outward normals times the quadrature weights
// (areas), m^2 Defects are relative to max_i sum_s v_s |grad w_is| (m^2).
ConsistentIntegrationReport make_integration_consistent(
    NeighbourTable &samples, std::vector<double> &volumes,
    const std::vector<double> &sample_points, const MeshlessShape &shape,
    const NeighbourTable &boundary, const std::vector<double> &boundary_points,
    const std::vector<double> &boundary_normals);

} // namespace fascia
