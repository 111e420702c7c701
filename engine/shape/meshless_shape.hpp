// Meshless shape functions for the frame method (paper §2.1: "many shape
// functions can be used, like the MLS [BLG94], compactly supported radial basis
// functions [LJ95]"), with analytic rest-space gradients, and the neighbour
// table that stores them.
//
// Conforming fields. Each frame i carries a support radius rho_i (m), fixed
// once from the local frame spacing (frame_supports), and a kernel phi_i(x) =
// phi(|x - x_i| / rho_i) with Wendland's C2 function phi(q) = (1 - q)^4 (4 q +
// 1) for q < 1, else 0. The shape functions w_i(x) are then one field per
// frame, defined everywhere in the union of the supports: every sample, probe
// and boundary point evaluates the same functions, and the stored gradients are
// their exact derivatives. Frame i is a neighbour of a point x when |x - x_i| <
// rho_i.
//
// Moving least squares with the linear basis P(y) = [1, (y - c) / h]
// (Belytschko, Lu & Gu 1994): w_i(x) = P(x)^T A(x)^-1 phi_i(x) P(x_i), A =
// sum_j phi_j P(x_j) P(x_j)^T. The field does not depend on the basis centre c
// or scale h (they change the basis of the same linear space), so c = x and h =
// the mean support only condition A. Partition of unity and linear precision:
// sum w_i = 1, sum w_i x_i = x, sum grad w_i = 0, sum x_i grad w_i^T = I.
//
// With frames (eq. 8) F = sum_i (x_i + R_i l_i) grad w_i^T + w_i R_i and l_i =
// p - x_i at rest, so at rest F = p (sum grad w_i)^T + sum w_i I = I (partition
// of unity), rigid motions give F = R, and frames moved by x -> A x + t with R
// = I give F = A (linear precision: the affine patch test). A
// Shepard-normalised kernel (w_i = phi_i / sum phi_j) has no linear precision:
// F = I + (A - I) G with G = sum x_i grad w_i^T != I, and its Galerkin
// solutions do not converge under refinement; it is not offered.
#pragma once

#include "core/small_math.hpp"
#include "model/model.hpp"

#include <vector>

namespace fascia {

// Wendland C2 kernel value and derivative d phi / d q.
double wendland_c2(double q);
double wendland_c2_derivative(double q);

// Weights and rest-space gradients (1/m) at x of the `count` frames at `frames`
// with supports `supports` (m); gradients null: the weights alone (the same
// bits), without the moment matrix's derivatives. Returns false (outputs
// unspecified) when the moment matrix is singular (fewer than 4 frames cover x,
// or all coplanar).
bool meshless_shape(const Vec3 &x, const Vec3 *frames, const double *supports,
                    int count, double *weights, Vec3 *gradients);

// How well the frames surround x: sqrt(lambda_min / lambda_max) of the
// kernel-weighted covariance of the frame positions, in [0, 1] (0 = coplanar,
// about 0.5 to 1 inside a Poisson-disk cloud). `weak` receives the eigenvector
// of lambda_min.
double neighbour_spread(const Vec3 &x, const Vec3 *frames,
                        const double *supports, int count, Vec3 &weak);

struct MeshlessShapeOptions {
  // rho_i = support_scale * the distance from frame i to its
  // support_neighbours-th nearest other frame: about 2.2 r_f inside a
  // Poisson-disk cloud of radius r_f, more at its boundary, where fewer frames
  // surround the points (see frame_supports).
  int support_neighbours = 8;
  double support_scale = 1.6;
};

// The shape functions of a set of frames: positions and supports, enough to
// evaluate the fields anywhere (samples, probes, surface points).
struct MeshlessShape {
  std::vector<double> frames;   // [N][3] m, rest positions
  std::vector<double> supports; // [N] rho_i, m
};

// Supports from the local frame spacing (options above); a lone frame gets
// support_scale times the largest extent of the cloud, or 1 m. nanoflann
// kd-tree, OpenMP over frames.
MeshlessShape make_meshless_shape(std::vector<double> frames,
                                  const MeshlessShapeOptions &options);

struct MeshlessTable {
  NeighbourTable neighbours; // weights, gradients, rest offsets l = p - x_i
  std::vector<double>
      spreads; // [S] neighbour_spread (0 where the shape failed)
  std::vector<double> weak_directions; // [S][3]
  std::vector<int> failed; // points whose shape functions could not be built
                           // (no frame covers them, or a singular MLS moment
                           // matrix); they carry equal weights and zero
                           // gradients so the table stays valid
};

// The shape functions at `points` ([S][3] m): neighbour search with a nanoflann
// kd-tree, OpenMP over blocks of points, output independent of the thread
// count. No cap on the neighbours; a point's neighbours in increasing frame
// index. weights_only: no weight gradients (neighbours.weight_gradients empty),
// spreads or weak directions (empty), for points that only interpolate (the
// boundary rule of consistent_integration.hpp).
MeshlessTable build_meshless_table(const MeshlessShape &shape,
                                   const std::vector<double> &points,
                                   bool weights_only = false);

} // namespace fascia
