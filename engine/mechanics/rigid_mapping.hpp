// The rigid mapping of frames attached to rigid bodies (paper §4.2: "the frames of the connective
// tissues of the interface (i.e. which lie on the rigid surface) have a rigid motion w.r.t. the
// rigid body"). Frame a attached to body frame b (Model::rigid_parents) is eliminated from the
// unknowns:
//   x_a = x_b + R_b c_a,  R_a = R_b,  c_a = x_a0 - x_b0 (rest orientations are identity).
// For an increment theta_b = [u, w] of the body, the attached frame's increment is exactly
//   theta_a = [u + (exp([w]x) - I) r_a, w],  r_a = x_a - x_b,
// so with J_a = [[I, -[r_a]x], [0, I]] a potential Phi(theta) reduces to
//   gradient:  g_b += J_a^T g_a
//   Hessian:   H_red = P^T H P + sum_a G_a,  G_a (rotation-rotation block of b) = the second
//              derivative of f . (w x (w x r_a)) / 2 = (f r_a^T + r_a f^T)/2 - (f . r_a) I,
//              f = the translational gradient g_a (the mapping's geometric term),
// P the 6N x 6N matrix with identity on unmapped frames and J_a in the columns of b for row a.
#pragma once

#include "model/state.hpp"

#include <Eigen/SparseCore>

#include <cstdint>
#include <vector>

namespace fascia {

class RigidMapping {
 public:
  explicit RigidMapping(const Model& model);

  bool empty() const { return m_mapped.empty(); }
  // Mapped frames and their bodies.
  const std::vector<int>& mapped() const { return m_mapped; }
  const std::vector<int>& bodies() const { return m_bodies; }

  // Positions and orientations of the mapped frames from their bodies.
  void sync(State& state) const;

  // Stores r_a = x_a - x_b at state (state must be synced); used by the operations below.
  void set_state(const State& state);
  // v_b += J_a^T v_a, then v_a = 0, for every mapped frame a (v [N][6]).
  void reduce(double* v) const;
  // d_a = J_a d_b for every mapped frame a, in place (d [N][6]).
  void expand(double* d) const;
  // Stores the translational gradients g_a of the unreduced potential for the geometric term.
  void set_geometric(const double* gradient);
  // out_b(rotation) += G_a d_b(rotation).
  void add_geometric(const double* d, double* out) const;
  // blocks_b += J_a^T blocks_a J_a + G_a; blocks_a = identity (mapped frames are not unknowns).
  // Omits the coupling blocks between two frames mapped to the same body (a preconditioner).
  void reduce_diagonal_blocks(double* blocks) const;
  // P as above.
  Eigen::SparseMatrix<double> projection(int dof_count) const;
  // The geometric terms as a sparse matrix.
  Eigen::SparseMatrix<double> geometric_matrix(int dof_count) const;
  // model.fixed_dofs with every mapped frame's DOFs fixed.
  std::vector<std::uint8_t> reduced_fixed(const Model& model) const;

 private:
  std::vector<int> m_mapped, m_bodies;
  std::vector<double> m_rest_offsets;  // [A][3] c_a
  std::vector<double> m_offsets;       // [A][3] r_a at the current state
  std::vector<double> m_forces;        // [A][3] g_a (translation)
};

}  // namespace fascia
