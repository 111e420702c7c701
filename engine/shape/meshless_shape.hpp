// Meshless shape functions for the frame method (paper §2.1: "many shape functions can be used,
// like the MLS [BLG94], compactly supported radial basis functions [LJ95]"), with analytic
// rest-space gradients, and the neighbour table that stores them.
//
// Kernel: Wendland's C2 function phi(q) = (1 - q)^4 (4 q + 1) for q = |x - x_i| / rho < 1, else 0.
//
// * rbf: Shepard-normalised kernel, w_i = phi_i / sum_j phi_j. Partition of unity
//   (sum w = 1, sum grad w = 0) but no linear precision (sum x_i grad w_i^T != I).
// * mls: moving least squares with the linear basis P(y) = [1, (y - c) / rho] (Belytschko, Lu &
//   Gu 1994), w_i(x) = P(x)^T A(x)^-1 phi_i(x) P(x_i), A = sum_j phi_j P(x_j) P(x_j)^T. Partition
//   of unity and linear precision: sum w_i x_i = x and sum x_i grad w_i^T = I.
//
// With frames (eq. 8) F = sum_i (x_i + R_i l_i) grad w_i^T + w_i R_i and l_i = p - x_i at rest,
// so at rest F = p (sum grad w_i)^T + sum w_i I = I for ANY partition of unity: both kinds give
// F = I at rest and rigid-motion invariance. Only mls passes the affine patch test (frames moved
// by x -> A x + t with R = I give F = A); rbf gives F = I + (A - I) G with G = sum x_i grad w_i^T.
//
// Support: rho_s is frozen per sample (the k-nearest radius varies between samples); the stored
// gradients are the exact derivatives of the sample's own field (fixed neighbour set and rho_s),
// which keeps both consistency identities above exact at every sample.
#pragma once

#include "core/small_math.hpp"
#include "model/model.hpp"

#include <vector>

namespace fascia {

enum class MeshlessShapeKind { mls, rbf };

// Wendland C2 kernel value and derivative d phi / d q.
double wendland_c2(double q);
double wendland_c2_derivative(double q);

// Weights and rest-space gradients (1/m) at x of the `count` frames at `frames` with support rho,
// basis centre c = x. Returns false (outputs unspecified) when sum phi = 0 or, for mls, the
// moment matrix is singular (fewer than 4 frames in the support, or all coplanar).
bool meshless_shape(MeshlessShapeKind kind, const Vec3& x, const Vec3* frames, int count, double rho,
                    double* weights, Vec3* gradients);
// The same with an explicit basis centre c (the derivative is taken with c fixed); used by the
// finite-difference tests to move x while keeping the sample's field.
bool meshless_shape(MeshlessShapeKind kind, const Vec3& x, const Vec3& c, const Vec3* frames, int count, double rho,
                    double* weights, Vec3* gradients);

// How well the frames surround x: sqrt(lambda_min / lambda_max) of the kernel-weighted
// covariance of the frame positions, in [0, 1] (0 = coplanar, about 0.5 to 1 inside a
// Poisson-disk cloud). `weak` receives the eigenvector of lambda_min.
double neighbour_spread(const Vec3& x, const Vec3* frames, int count, double rho, Vec3& weak);

struct MeshlessShapeOptions {
  MeshlessShapeKind kind = MeshlessShapeKind::mls;
  int neighbours = 12;         // k nearest frames per sample; 0: every frame within support_radius
  double support_scale = 1.5;  // rho_s = support_scale * distance to the k-th nearest frame (> 1)
  double support_radius = 0;   // rho (m) when neighbours == 0
};

struct MeshlessTable {
  NeighbourTable neighbours;            // weights, gradients, rest offsets l = p - x_i
  std::vector<double> supports;         // [S] rho_s, m
  std::vector<double> spreads;          // [S] neighbour_spread (0 where the shape failed)
  std::vector<double> weak_directions;  // [S][3]
  std::vector<int> failed;              // samples whose shape functions could not be built;
                                        // they carry Shepard weights so the table stays valid
};

// Neighbour search with a nanoflann kd-tree over the frames; OpenMP over blocks of samples,
// output independent of the thread count. No cap on the number of neighbours.
MeshlessTable build_meshless_table(const std::vector<double>& frames, const std::vector<double>& samples,
                                   const MeshlessShapeOptions& options);

}  // namespace fascia
