// The rotation stabilisation of frame hexahedra (engine/mechanics/rotation_stabilisation.hpp) on
// the device: the CUDA driver of the per-edge body of mechanics/edge_twist.hpp, the same body the
// CPU's RotationStabilisation loops over, with the CPU's edges. One thread per edge evaluates the
// body into the per-edge buffers of DeviceElementTerms (device_element_terms.hpp: 2 nodes, the
// translational rows and columns zero), which sums them per frame and per block of the tangent
// pattern in edge order.
#pragma once

#include "device_buffers.cuh"
#include "device_element_terms.hpp"
#include "device_vector.hpp"
#include "mechanics/edge_twist.hpp"
#include "model/model.hpp"

#include <vector>

namespace fascia::gpu {

class DeviceStabilisation {
 public:
  // The model's twist edges (none where RotationStabilisation::applies is false: empty()).
  explicit DeviceStabilisation(const Model& model);

  bool empty() const { return m_edges == 0; }

  // Device arrays: q [N][4], vectors [N][6], blocks [N][36]; work on ops.stream().
  // S at q (J).
  double energy(const double* q, const VectorOps& ops);
  // Adds dS/d(theta) to g; returns S.
  double add_gradient(const double* q, double* g, const VectorOps& ops);
  // Stores every edge's Hessian at q.
  void prepare(const double* q, cudaStream_t stream);
  // out += K_S d with the prepared Hessians.
  void add_tangent(const double* d, double* out, cudaStream_t stream) { m_terms.add_tangent(d, out, stream); }
  // blocks += the edges' 6x6 diagonal blocks of the prepared Hessians.
  void add_diagonal_blocks(double* blocks, cudaStream_t stream) const { m_terms.add_diagonal_blocks(blocks, stream); }
  // The block pattern of add_tangent_blocks (DeviceElementTerms::set_tangent_blocks).
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames) {
    m_terms.set_tangent_blocks(block_offsets, block_frames);
  }
  // blocks [B][36] += the prepared Hessians' blocks of the pattern between an edge's frames.
  void add_tangent_blocks(double* blocks, cudaStream_t stream) const { m_terms.add_tangent_blocks(blocks, stream); }

 private:
  explicit DeviceStabilisation(const std::vector<EdgeTwist>& edges);
  int m_edges = 0;
  DeviceBuffer<EdgeTwist> m_twists;  // [E]
  DeviceElementTerms m_terms;        // 2 nodes per edge
};

}  // namespace fascia::gpu
