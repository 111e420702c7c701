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

// The per-frame and per-block sums, the tangent product and the blocks are DeviceElementTerms'
// (2 nodes per edge).
class DeviceStabilisation : public DeviceElementTerms {
 public:
  // The model's twist edges (none where RotationStabilisation::applies is false: empty()).
  explicit DeviceStabilisation(const Model& model);

  // Device arrays: q [N][4], vectors [N][6]; work on ops.stream().
  // S at q (J) as ops's next pending term (VectorOps::read_pending; none without edges).
  void energy(const double* q, const VectorOps& ops);
  // Adds dS/d(theta) to g; S as energy() leaves it.
  void add_gradient(const double* q, double* g, const VectorOps& ops);
  // Stores every edge's Hessian at q.
  void prepare(const double* q, cudaStream_t stream);

 private:
  explicit DeviceStabilisation(const std::vector<EdgeTwist>& edges);
  DeviceBuffer<EdgeTwist> m_twists;  // [E]
};

}  // namespace fascia::gpu
