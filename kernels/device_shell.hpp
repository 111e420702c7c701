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
  void add_tangent(const double* d, double* out, cudaStream_t stream) { m_terms.add_tangent(d, out, stream); }
  // blocks += the shells' 6x6 diagonal blocks of the prepared Hessians.
  void add_diagonal_blocks(double* blocks, cudaStream_t stream) const { m_terms.add_diagonal_blocks(blocks, stream); }
  // The block pattern of add_tangent_blocks (DeviceElementTerms::set_tangent_blocks).
  void set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames) {
    m_terms.set_tangent_blocks(block_offsets, block_frames);
  }
  // blocks [B][36] += the prepared Hessians' blocks (a, b) with b <= a of the pattern, between two
  // nodes of a triangle (a == b: one node's diagonal block).
  void add_tangent_blocks(double* blocks, cudaStream_t stream) const { m_terms.add_tangent_blocks(blocks, stream); }

 private:
  DeviceShells(const std::vector<ShellElementRest>& elements, const std::vector<ShellModuli>& moduli);
  int m_triangles = 0;
  DeviceBuffer<ShellElementRest> m_elements;  // [T]
  DeviceBuffer<ShellModuli> m_moduli;         // [T] the moduli of each triangle's shell
  DeviceElementTerms m_terms;                 // 3 nodes per triangle
};

}  // namespace fascia::gpu
