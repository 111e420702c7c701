// A force field: one energy contribution on the frame configuration, with the gradient and the
// symmetric Hessian of theta -> W(q (+) theta) at theta = 0 (DESIGN.md). One mechanical system
// sums several of them into the same frame degrees of freedom: frames shared between objects
// (paper §4.2, Figure 5) simply receive the sum of every field's forces and tangents.
//
// Shapes: gradients and products are [N][6] (translation N, then world-axis rotation N m),
// diagonal blocks [N][36] row-major, matrix entries are (row, col) in the 6N x 6N tangent.
#pragma once

#include "model/state.hpp"

#include <Eigen/SparseCore>

#include <vector>

namespace fascia {

class ForceField {
 public:
  virtual ~ForceField() = default;
  // W in J.
  virtual double energy(const State& state) = 0;
  // Adds dW/d(theta) to gradient [N][6]; returns W.
  virtual double add_gradient(const State& state, double* gradient) = 0;
  // Precomputes the tangent at state for the products below.
  virtual void prepare(const State& state) = 0;
  // out += K d, d and out [N][6].
  virtual void add_tangent(const double* d, double* out) const = 0;
  // blocks += the 6x6 diagonal blocks K_ii, [N][36].
  virtual void add_diagonal_blocks(double* blocks) const = 0;
  // Appends the entries of K (both triangles; duplicates are summed by setFromTriplets).
  virtual void add_triplets(std::vector<Eigen::Triplet<double>>& triplets) const = 0;
};

}  // namespace fascia
