// The rigid mapping of engine/mechanics/rigid_mapping.hpp on the device: frames attached to rigid
// bodies follow their body and leave the unknowns (x_a = x_b + R_b c_a, R_a = R_b). The same
// operations (sync, reduce, expand, the geometric term, the reduced diagonal blocks) over device
// arrays, in the CPU's order: every sum into a body runs over its attached frames in the order of
// RigidMapping::mapped(), one thread per body, so results are deterministic and need no atomics.
#pragma once

#include "device_buffers.cuh"
#include "model/model.hpp"

#include <cstdint>
#include <vector>

namespace fascia::gpu {

class DeviceRigidMapping {
 public:
  explicit DeviceRigidMapping(const Model& model);

  bool empty() const { return m_count == 0; }
  // model.fixed_dofs with every mapped frame's DOFs fixed (host), as RigidMapping::reduced_fixed.
  const std::vector<std::uint8_t>& reduced_fixed() const { return m_reduced_fixed; }

  // Device arrays: x [N][3], q [N][4], vectors [N][6], blocks [N][36]; work on `stream`.
  void sync(double* x, double* q, cudaStream_t stream) const;
  // Stores r_a = x_a - x_b (x synced).
  void set_state(const double* x, cudaStream_t stream);
  // Stores the translational gradients g_a of the unreduced potential.
  void set_geometric(const double* gradient, cudaStream_t stream);
  // v_b += J_a^T v_a, then v_a = 0.
  void reduce(double* v, cudaStream_t stream) const;
  // The reduced tangent product from the unreduced one: out_b += J_a^T out_a, out_a = 0, then
  // out_b(rotation) += G_a d_b(rotation) (reduce, then the geometric term, in one pass).
  void reduce_product(const double* d, double* out, cudaStream_t stream) const;
  // out = d with d_a = J_a d_b (the expanded vector, in one pass over the frames).
  void expand(const double* d, double* out, cudaStream_t stream) const;
  // blocks_b += J_a^T blocks_a J_a + G_a; blocks_a = identity.
  void reduce_diagonal_blocks(double* blocks, cudaStream_t stream) const;

 private:
  int m_count = 0, m_bodies = 0, m_frames = 0;
  std::vector<std::uint8_t> m_reduced_fixed;
  DeviceBuffer<int> m_mapped, m_parent;           // [A] frame a, its body b
  DeviceBuffer<int> m_slot;                       // [N] each frame's index k in m_mapped, -1 if not mapped
  DeviceBuffer<int> m_body, m_body_offsets;       // [B] body frames, [B+1] ranges into m_body_entries
  DeviceBuffer<int> m_body_entries;               // [A] mapped indices k grouped by body, ascending k
  DeviceBuffer<double> m_rest_offsets, m_offsets, m_forces;  // [A][3] c_a, r_a, g_a
};

}  // namespace fascia::gpu
