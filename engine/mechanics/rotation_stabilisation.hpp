// Stabilisation of the zero-energy rotation modes of frame hexahedra (docs/solvers.md, "Zero-energy
// modes of frame hexahedra").
//
// With trilinear shape functions w_i = N_a(xi) N_b(eta) N_c(zeta), the frames of one layer of a
// hexahedral grid (one cross-section of a beam) can turn together about the layer's normal n
// without moving any point: sum_{b,c} N_b N_c (p - x_abc) is parallel to n on a parallelepiped,
// so sum_i w_i dr_i x (p - x_i) = 0 when every frame of layer a turns by dr_a = theta_a n. F and
// the elastic energy do not change and the static tangent is singular. What such a mode changes
// is the relative rotation of the frames at the two ends of each hexahedron edge along n, about n:
// a twist of the edge. The term below penalises that twist:
//
//   W_stab = sum_s sum_{edges (i, j) of s's hexahedron} k_s / 2 tau_ij^2 / 4,
//   tau_ij = e_ij . axial(R_i^T R_j),   k_s = kappa mu_s v_s / 12,
//
// e_ij the edge's rest direction (unit). For a relative rotation by phi about the axis u (in frame
// i's axes), axial(R_i^T R_j) = -2 sin(phi) u, so tau^2 / 4 = sin^2(phi) (e . u)^2 ~ phi_twist^2:
// bending (relative rotations about axes across the edge) is not penalised, and
// rigid rotations of the whole body leave R_i^T R_j unchanged. phi_twist ~ h (e . grad)(e . rho)
// for a smooth field of frame rotations rho, so the term is an energy density
// kappa mu h^2 |d rho_e / d e|^2 / 24 that vanishes as h^2 in the continuum limit.
//
// Gradient and symmetric Hessian of theta -> W(q (+) theta) at theta = 0 are exact: with
// C = R_i^T R_j, dC[d] = R_i^T [d_j - d_i]x R_j and
// d2C[d, e] = R_i^T (sym([d_i]x [e_i]x) - [d_i]x [e_j]x - [e_i]x [d_j]x + sym([d_j]x [e_j]x)) R_j.
// The term involves only the rotations of the edge's two frames; one edge's energy, gradient and
// Hessian are mechanics/edge_twist.hpp, shared with the CUDA driver.
// Only samples flagged in model.samples.rotation_stabilised carry it: hexahedral samples whose 8
// neighbours are the cell's corners in VTK order.
#pragma once

#include "mechanics/edge_twist.hpp"
#include "mechanics/force_field.hpp"
#include "model/model.hpp"

#include <vector>

namespace fascia {

// kappa: the edge twist stiffness as a fraction of the shear stiffness mu v of the cell
// (docs/solvers.md: the smallest decade that keeps the frame-hex study rows converging in a
// few Newton iterations; it changes their tip deflections by less than the bound derived there).
constexpr double kRotationStabilisation = 1e-2;

class RotationStabilisation : public ForceField {
 public:
  // @param threads unused (the term is a few operations per edge).
  explicit RotationStabilisation(const Model& model, int threads = 0, double kappa = kRotationStabilisation);

  double energy(const State& state) override;
  double add_gradient(const State& state, double* gradient) override;
  void prepare(const State& state) override;
  void add_tangent(const double* d, double* out) const override;
  void add_diagonal_blocks(double* blocks) const override;
  void add_triplets(std::vector<Eigen::Triplet<double>>& triplets) const override;

  // Whether the model has samples that carry the term (and free rotations).
  static bool applies(const Model& model);
  int edge_count() const { return static_cast<int>(m_edges.size()); }
  // The edges, i < j, each once, with k_e = the sum over the edge's samples of kappa mu v / 12 (J).
  const std::vector<EdgeTwist>& edges() const { return m_edges; }

 private:
  std::vector<EdgeTwist> m_edges;
  std::vector<double> m_hessians;  // [E][6][6] prepared: rows/cols (dr_i, dr_j)
};

}  // namespace fascia
