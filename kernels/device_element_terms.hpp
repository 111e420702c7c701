// The frame-side half of a force field made of small elements on the device, the base of its
// driver (the shells' triangles, device_shell.hpp; the stabilisation's edges,
// device_stabilisation.hpp): each element couples k frames, 6 DOFs each ([dx, dr] per node), and
// the driver's kernels store per element its energy, its gradient [6k] or its Hessian [6k][6k] in
// the buffers here. This class sums
// them per frame and per block of the tangent pattern in a fixed order (a frame's (element, node)
// entries, a block's (element, node, node) terms, in element order), so that results are
// deterministic without atomics, and multiplies the prepared Hessians by a direction.
#pragma once

#include "device_buffers.cuh"
#include "device_vector.hpp"

#include <vector>

namespace fascia::gpu {

class DeviceElementTerms {
 public:
  // nodes: [T][k] each element's frames.
  DeviceElementTerms(int nodes_per_element, const std::vector<int>& nodes);

  bool empty() const { return m_elements == 0; }
  int count() const { return m_elements; }
  int element_dofs() const { return 6 * m_nodes_per_element; }

  // out += K d with the prepared Hessians (d [N][6]).
  void add_tangent(const double* d, double* out, cudaStream_t stream);
  // blocks [N][36] += each frame's 6x6 diagonal blocks of the prepared Hessians.
  void add_diagonal_blocks(double* blocks, cudaStream_t stream) const;
  // The block pattern of add_tangent_blocks (integrate/tangent_probing.hpp: host CSR over rows
  // a, block_offsets [N+1], block_frames [B]).
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames);
  // blocks [B][36] += the prepared Hessians' blocks (a, b) with b <= a of the pattern, between two
  // nodes of an element (a == b: one node's diagonal block).
  void add_tangent_blocks(double* blocks, cudaStream_t stream) const;

 protected:
  // Per-element buffers for the driver's kernels: energies [T], values [T][6k] (gradients or
  // products), hessians [T][6k][6k].
  double* energies() { return m_energies.data(); }
  double* values() { return m_values.data(); }
  double* hessians() { return m_hessians.data(); }
  // The sum of the elements' energies (J), in a fixed order, as ops's next pending term
  // (VectorOps::dot_pending).
  void energy_sum(const VectorOps& ops) const;
  // out [N][6] += each frame's entries of values() (gradients: after the driver stored them).
  void gather(double* out, cudaStream_t stream) const;

 private:
  int m_nodes_per_element = 0, m_elements = 0, m_frames = 0;
  std::vector<int> m_host_nodes;  // [T][k]
  DeviceBuffer<int> m_nodes;      // [T][k]
  // Frames the elements touch: m_frame_ids [F], their entries [m_offsets[f], m_offsets[f + 1]) in
  // m_entries = k t + local node, in element order.
  DeviceBuffer<int> m_frame_ids, m_offsets, m_entries;
  // The pattern's blocks that elements touch: m_block_ids [K], their terms [m_block_offsets[k],
  // m_block_offsets[k + 1]) in m_block_terms = k^2 t + k node_a + node_b, in element order.
  int m_touched_blocks = 0;
  DeviceBuffer<int> m_block_ids, m_block_offsets, m_block_terms;
  DeviceBuffer<double> m_values;    // [T][6k]
  DeviceBuffer<double> m_energies;  // [T]
  DeviceBuffer<double> m_hessians;  // [T][6k][6k]
};

}  // namespace fascia::gpu
