// The shells of a model (engine/mechanics/shell.hpp) on the device: the CUDA driver of the
// per-triangle body of mechanics/shell_element.hpp (energy, gradient, Hessian of one corotational
// triangle in closed form), the same body the CPU's ShellForceField loops over.
//
// One thread per triangle evaluates the body; a second pass sums each frame's element terms in a
// fixed order (its (triangle, node) entries in triangle order), so that results are deterministic
// without atomics. The prepared Hessians are kept per triangle ([T][18][18]); the tangent
// product multiplies them per triangle and sums per frame like the gradient, and the tangent's
// blocks sum them per block of a pattern, again in triangle order.
#pragma once

#include "device_buffers.cuh"
#include "device_vector.hpp"
#include "mechanics/shell_element.hpp"
#include "model/model.hpp"

#include <vector>

namespace fascia::gpu {

class DeviceShells {
 public:
  // Every shell of the model (none: empty()).
  explicit DeviceShells(const Model& model);

  bool empty() const { return m_triangles == 0; }

  // Device arrays: x [N][3], q [N][4], vectors [N][6], blocks [N][36]; work on ops.stream().
  // W of the shells at (x, q) (J).
  double energy(const double* x, const double* q, const VectorOps& ops);
  // Adds dW/d(theta) to g; returns W.
  double add_gradient(const double* x, const double* q, double* g, const VectorOps& ops);
  // Stores every triangle's Hessian at (x, q).
  void prepare(const double* x, const double* q, cudaStream_t stream);
  // out += K d with the prepared Hessians.
  void add_tangent(const double* d, double* out, cudaStream_t stream);
  // blocks += the shells' 6x6 diagonal blocks of the prepared Hessians.
  void add_diagonal_blocks(double* blocks, cudaStream_t stream) const;
  // The block pattern of add_tangent_blocks (integrate/tangent_probing.hpp: host CSR over rows
  // a, block_offsets [N+1], block_frames [B]).
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames);
  // blocks [B][36] += the prepared Hessians' blocks (a, b) with b <= a of the pattern, between two
  // nodes of a triangle (a == b: one node's diagonal block).
  void add_tangent_blocks(double* blocks, cudaStream_t stream) const;

 private:
  int m_triangles = 0, m_frames = 0;
  DeviceBuffer<ShellElementRest> m_elements;  // [T]
  DeviceBuffer<ShellModuli> m_moduli;         // [T] the moduli of each triangle's shell
  // Frames touched by shells: m_frame_ids [F], their entries [m_offsets[f], m_offsets[f + 1]) in
  // m_entries = 3 t + local node, in triangle order.
  DeviceBuffer<int> m_frame_ids, m_offsets, m_entries;
  // The pattern's blocks that triangles touch: m_block_ids [K], their terms [m_block_offsets[k],
  // m_block_offsets[k + 1]) in m_block_terms = 9 t + 3 node_a + node_b, in triangle order.
  int m_touched_blocks = 0;
  std::vector<int> m_nodes;  // [T][3] each triangle's frames (host)
  DeviceBuffer<int> m_block_ids, m_block_offsets, m_block_terms;
  DeviceBuffer<double> m_values;    // [T][18] per-triangle gradients or products
  DeviceBuffer<double> m_energies;  // [T]
  DeviceBuffer<double> m_hessians;  // [T][18][18]
};

}  // namespace fascia::gpu
