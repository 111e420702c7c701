// The discretised mechanical model: frames (6-DOF), samples (3-DOF integration points), the
// paper's neighbour and reverse tables (§3.1) and per-frame constraints.
//
// All tables are structure-of-arrays of plain contiguous buffers so that kernels/ uploads them
// unchanged. Notation: N frames, S samples, P sample-frame pairs (neighbour entries).
#pragma once

#include "material/material.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace fascia {

// Per-sample neighbour table in compressed-row form (paper §3.1): the neighbours of sample s are
// pairs p in [offsets[s], offsets[s+1]). No cap on the number of neighbours.
struct NeighbourTable {
  std::vector<int> offsets;              // [S+1]
  std::vector<int> frames;               // [P]     frame index i of pair p
  std::vector<double> weights;           // [P]     w_is, dimensionless
  std::vector<double> weight_gradients;  // [P][3]  grad w_is in rest space, 1/m
  std::vector<double> rest_offsets;      // [P][3]  l_is = R_i^T (p_s - x_i) at rest, m (eq. 2)
};

// Reverse indirection table (paper §3.1, Figure 1): the pairs that touch frame i are
// pairs[offsets[i] .. offsets[i+1]), in increasing pair order.
struct ReverseTable {
  std::vector<int> offsets;         // [N+1]
  std::vector<int> pairs;           // [P]
  std::vector<int> pair_samples;    // [P] sample s of pair p
};

struct Samples {
  std::vector<double> rest_positions;  // [S][3] m
  std::vector<double> volumes;         // [S]    m^3, sum = object volume
  std::vector<int> materials;          // [S]    index into Model::materials
  // [S] 1 where the sample ties its frames' rotations to the rotation of F
  // (mechanics/rotation_stabilisation.hpp: trilinear hexahedra); empty = none.
  std::vector<std::uint8_t> rotation_stabilised;
};

// A shell (paper §4.2, after Comas, Duriez & Cotin 2010): a triangle surface whose vertices are
// frames used as 6-DOF shell nodes. The element is in mechanics/shell.hpp.
struct Shell {
  std::vector<int> triangles;  // [T][3] frame indices
  double thickness = 0;        // m
  double young = 0;            // Pa, > 0
  double poisson = 0;          // -1 < nu < 0.5
  double density = 0;          // kg/m^3
};

// What a model was assembled from (model/assembly.hpp), kept for output and selections.
enum class ObjectKind { tissue, shell, rigid };
const char* to_string(ObjectKind kind);

struct ObjectInfo {
  std::string name;
  ObjectKind kind = ObjectKind::tissue;
  std::vector<int> frames;        // the object's frames (global indices; shared frames appear in both)
  std::vector<double> surface_vertices;  // [V][3] m, rest surface
  std::vector<int> surface_triangles;    // [T][3]
};

// Degrees of freedom of frame i: 0..2 translation (world axes), 3..5 rotation increment (world).
constexpr int kFrameDofs = 6;

struct Model {
  std::vector<double> frame_rest_positions;  // [N][3] m; rest orientations are identity
  Samples samples;
  NeighbourTable neighbours;
  ReverseTable reverse;
  std::vector<Material> materials;

  // Lumped inertia from the samples (DESIGN.md): m_i = sum_s w_is rho_s v_s and the rotational
  // inertia about the frame origin, rest configuration, world axes.
  std::vector<double> frame_masses;    // [N]       kg
  std::vector<double> frame_inertias;  // [N][3][3] kg m^2

  // Mass carried at the frame origins themselves besides the samples' (shell nodes, rigid bodies'
  // centres of mass): gravity acts on it at x_i. Already included in frame_masses. Empty = none.
  std::vector<double> frame_point_masses;  // [N] kg

  // Shell force fields on frames (paper §4.2).
  std::vector<Shell> shells;

  // Rigid mapping (paper §4.2): frame i follows frame rigid_parents[i] (a rigid body's frame at
  // its centre of mass) rigidly when >= 0: x_i = x_b + R_b (x_i0 - x_b0), R_i = R_b. Such frames
  // are not unknowns. Empty = none.
  std::vector<int> rigid_parents;  // [N]

  std::vector<ObjectInfo> objects;

  // 1 where the degree of freedom is fixed (removed from the unknowns).
  std::vector<std::uint8_t> fixed_dofs;  // [N][6]

  // Frames used as 3-DOF nodes with R_i = I (classic total-Lagrangian FEM, paper Figure 3).
  bool rotations_locked = false;

  int frame_count() const { return static_cast<int>(frame_rest_positions.size() / 3); }
  int sample_count() const { return static_cast<int>(samples.volumes.size()); }
  int pair_count() const { return static_cast<int>(neighbours.frames.size()); }
  int dof_count() const { return kFrameDofs * frame_count(); }
  // Unknowns a user would count: 3 per frame with locked rotations, 6 otherwise.
  int nominal_dof_count() const { return (rotations_locked ? 3 : 6) * frame_count(); }
  int max_neighbours() const;
  double total_volume() const;
  double total_mass() const;
};

// Builds the reverse table (and the pair -> sample map) from the neighbour table.
void build_reverse_table(Model& model);

// Lumped frame masses and inertias from the sample densities (m_s = rho_s v_s; eq. 3 weights w_p,
// rest offsets l_p). Mass: m_i = sum_p w_p m_s, the row sums of the consistent mass matrix, which
// make a uniform translation exact under gravity (the same sums weigh the frames,
// mechanics/frame_loads.cpp). Inertia: I_i = sum_p m_p (|l_p|^2 I - l_p l_p^T) with the shares
// m_p = m_s w+_p / sum w+ (w+ = max(w, 0)): moving least squares weights of linear precision are
// negative in places, and with them a frame's inertia can be indefinite, and the step's Hessian
// with it once I / h^2 outweighs the elastic stiffness (small steps). The shares are the weights
// where those are non-negative (finite elements). A frame whose row sum is not positive takes the
// sum of its shares as its mass.
void compute_frame_inertia(Model& model);

// Fixes all six DOFs (or only the translations) of the frames whose rest position satisfies the
// predicate. Returns the number of frames selected.
template <class Predicate>
int fix_frames(Model& model, Predicate inside, bool translations_only = false) {
  int count = 0;
  model.fixed_dofs.resize(model.dof_count(), 0);
  for (int i = 0; i < model.frame_count(); ++i) {
    const double* x = &model.frame_rest_positions[3 * i];
    if (!inside(x[0], x[1], x[2])) continue;
    ++count;
    for (int k = 0; k < (translations_only ? 3 : 6); ++k) model.fixed_dofs[kFrameDofs * i + k] = 1;
  }
  return count;
}

// Locks the rotations of every frame (R_i = I): frames act as 3-DOF nodes.
void lock_rotations(Model& model);

// Checks the tables for consistency (sizes, indices in range, positive volumes); throws
// std::invalid_argument with a message naming the first problem.
void validate(const Model& model);

}  // namespace fascia
