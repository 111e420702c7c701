// The shells of a model (engine/mechanics/shell.hpp) on the device: the CUDA driver of the
// per-triangle body of mechanics/shell_element.hpp (energy, gradient, Hessian of one corotational
// triangle in closed form), the same body the CPU's ShellForceField loops over.
//
// One thread per triangle evaluates the body into the per-triangle buffers of DeviceElementTerms
// (device_element_terms.hpp), which sums them per frame and per block of the tangent pattern in
// triangle order and multiplies the prepared Hessians ([T][18][18]) by a direction.
#pragma once

#include "device_buffers.cuh"
#include "device_element_terms.hpp"
#include "device_vector.hpp"
#include "mechanics/shell_element.hpp"
#include "model/model.hpp"

#include <vector>

namespace fascia::gpu {

// The per-frame and per-block sums, the tangent product and the blocks are DeviceElementTerms'
// (3 nodes per triangle).
class DeviceShells : public DeviceElementTerms {
 public:
  // Every shell of the model (none: empty()).
  explicit DeviceShells(const Model& model);

  // Device arrays: x [N][3], q [N][4], vectors [N][6]; work on ops.stream().
  // W of the shells at (x, q) (J) as ops's next pending term (VectorOps::read_pending; none
  // without shells).
  void energy(const double* x, const double* q, const VectorOps& ops);
  // Adds dW/d(theta) to g; W as energy() leaves it.
  void add_gradient(const double* x, const double* q, double* g, const VectorOps& ops);
  // Stores every triangle's Hessian at (x, q).
  void prepare(const double* x, const double* q, cudaStream_t stream);

 private:
  DeviceShells(const std::vector<ShellElementRest>& elements, const std::vector<ShellModuli>& moduli);
  DeviceBuffer<ShellElementRest> m_elements;  // [T]
  DeviceBuffer<ShellModuli> m_moduli;         // [T] the moduli of each triangle's shell
};

}  // namespace fascia::gpu
