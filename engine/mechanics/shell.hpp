// Corotational triangular shell with 6-DOF nodes (paper §4.2; after Comas, Duriez & Cotin 2010,
// who combine a membrane triangle with a DKT plate in the triangle's corotational frame).
//
// Each triangle's energy W_e = W_membrane + W_bending + W_drilling is written once as a function
// of its three frames (x_i, R_i):
//  * membrane: constant-strain triangle with the Green-Lagrange strain of the mid-surface,
//    E = (F^T F - I)/2, F = [x1-x0, x2-x0] Dm^{-1} (3x2), evaluated in displacement form
//    E = sym(F0^T U) + U^T U / 2, F0 = [e1 e2] (rest), U = [u1-u0, u2-u0] Dm^{-1}, u = x - X:
//    forming F^T F - I directly loses all digits of strains below 1e-16 and leaves a force noise
//    that the stiff membrane (Y t) amplifies well above a small bending load; plane-stress StVK
//    W_m = A t (mu tr(E^2) + lambda*/2 tr(E)^2), mu = Y/(2(1+nu)), lambda* = Y nu/(1-nu^2).
//    Independent of any frame, so exactly invariant under rigid motions.
//  * bending: the Discrete Kirchhoff Triangle (Batoz, Bathe & Ho 1980) in the corotational frame
//    (e1 along x1-x0, e3 the triangle's normal). The plane passes through the three nodes, so the
//    local deflections w_i vanish and only the nodal slopes remain:
//    beta_i = grad w at node i = -(e1 . d_i, e2 . d_i), d_i = R_i e3_rest (the node's director).
//    DKT: beta quadratic, at mid-edges beta_k = (I/2 - 3/4 s s^T)(beta_i + beta_j) (Kirchhoff
//    along the edge: cubic w, linear normal slope), curvature kappa = [b_x,x, b_y,y, b_x,y + b_y,x]
//    (engineering twist), W_b = 1/2 int kappa^T D_b kappa dA, D_b = D [[1, nu, 0], [nu, 1, 0],
//    [0, 0, (1-nu)/2]], D = Y t^3 / (12 (1 - nu^2)); 3-point mid-edge rule (exact: kappa is linear).
//  * drilling: the nodes' rotations about the normal, psi_i = (e2 . R_i e1_rest - e1 . R_i e2_rest)/2,
//    have no physical stiffness in a Kirchhoff shell; a small penalty W_d = k_d/2 sum psi_i^2,
//    k_d = 1e-3 Y t A, removes the singular direction (ignorable next to membrane and bending).
// The rest state is stress free for curved surfaces (each triangle measures slopes against its
// own rest normal). Gradient and Hessian of theta -> W(q (+) theta) are exact and in closed form
// (mechanics/shell_element.hpp, which holds the per-triangle body shared with CUDA drivers).
// The triangles are evaluated four at a time, one per lane of DoubleLanes (core/double_lanes.hpp).
// prepare() sums the element Hessians into one 6x6 block per pair of frames that share a
// triangle, colour by colour (triangles of a colour share no frame); products, diagonal blocks and
// triplets read those blocks.
#pragma once

#include "core/double_lanes.hpp"
#include "core/small_math.hpp"
#include "mechanics/force_field.hpp"
#include "mechanics/shell_element.hpp"
#include "model/model.hpp"

#include <vector>

namespace fascia {

// Rest data of one triangle (throws std::invalid_argument on a degenerate triangle).
ShellElementRest make_shell_element(const double* rest_positions, int n0, int n1, int n2, const Shell& shell);

class ShellForceField : public ForceField {
 public:
  // Rest geometry from model.frame_rest_positions. @param threads OpenMP threads, 0 = default.
  ShellForceField(const Model& model, const Shell& shell, int threads = 0);

  double energy(const State& state) override;
  double add_gradient(const State& state, double* gradient) override;
  void prepare(const State& state) override;
  void add_tangent(const double* d, double* out) const override;
  void add_diagonal_blocks(double* blocks) const override;
  void add_triplets(std::vector<Eigen::Triplet<double>>& triplets) const override;

  int element_count() const { return static_cast<int>(m_elements.size()); }
  // Bending stiffness D = Y t^3 / (12 (1 - nu^2)), N m.
  double bending_stiffness() const;

 private:
  std::vector<ShellElementRest> m_elements;
  Shell m_shell;
  ShellModuli m_moduli;
  int m_threads;
  // Sparse block rows of the shell's tangent: one 6x6 block per pair of frames that share a
  // triangle (rows: the shell's frames, sorted), assembled by prepare() from the element Hessians.
  void build_block_structure();

  std::vector<int> m_row_frames;            // [rows] frame of each block row
  std::vector<int> m_row_offsets;           // [rows+1] blocks of row r: [offsets[r], offsets[r+1])
  std::vector<int> m_block_frames;          // [blocks] column frame of each block
  std::vector<int> m_diagonal_blocks;       // [rows] the (frame, frame) block of each row
  std::vector<int> m_element_blocks;        // [T][3][3] the block of each element's node pair (a, b)
  // Triangles by colour (no two of a colour share a node), then index, in lane groups of
  // kDoubleLanes, evaluated together.
  std::vector<int> m_colour_groups;                            // [colours+1] groups of colour c
  std::vector<int> m_group_members;                            // [G][kDoubleLanes] triangle per lane, -1: empty
  std::vector<ShellElementRestT<DoubleLanes>> m_lane_elements;  // [G] the groups' rest data, lane-packed
  std::vector<double> m_blocks;             // [blocks][6][6] column-major: entry (r, c) at 6 c + r
  std::vector<double> m_element_gradients;  // [T][18] scratch
  std::vector<double> m_element_energies;   // [T] scratch
};

// Lumped shell masses: each triangle gives rho t A / 3 to each vertex, and rotational inertia
// m_i A_i / 6 I (a square patch of the vertex's area A_i about its centre). Adds to
// model.frame_masses, frame_inertias and frame_point_masses.
void add_shell_masses(Model& model, const Shell& shell);

}  // namespace fascia
