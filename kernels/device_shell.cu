#include "device_shell.hpp"

#include "core/rotation.hpp"

#include <algorithm>

namespace fascia::gpu {
namespace {

constexpr int kThreads = 128;
int grid(int n) { return std::max(1, (n + kThreads - 1) / kThreads); }
void check() { FASCIA_CUDA(cudaGetLastError()); }

// The nodes' positions and rotations of triangle e.
__device__ void gather_nodes(const ShellElementRest& e, const double* x, const double* q, Vec3 (&xs)[3], Mat3 (&Rs)[3]) {
  for (int k = 0; k < 3; ++k) {
    xs[k] = load3(x + 3 * e.nodes[k]);
    Rs[k] = rotation_matrix(load_quat(q + 4 * e.nodes[k]));
  }
}

// What k_shell_elements evaluates per triangle besides its energy.
enum class ElementOutput { energy, gradient, hessian };

// Per triangle: its energy, and its gradient [18] into `values` or its Hessian [18][18] into
// `hessians`. One kernel per output: the Hessian's registers and stack (about 5 KB per thread)
// would otherwise be those of the energy and gradient too.
template <ElementOutput Output>
__global__ void k_shell_elements(int count, const ShellElementRest* elements, const ShellModuli* moduli,
                                 const double* x, const double* q, double* energies, double* values,
                                 double* hessians) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= count) return;
  const ShellElementRest e = elements[t];
  Vec3 xs[3];
  Mat3 Rs[3];
  gather_nodes(e, x, q, xs, Rs);
  if constexpr (Output == ElementOutput::hessian) {
    double g[kShellElementDofs];
    energies[t] = shell_element_hessian(e, moduli[t], xs, Rs, g,
                                        hessians + static_cast<long long>(t) * kShellElementDofs * kShellElementDofs);
  } else if constexpr (Output == ElementOutput::gradient) {
    energies[t] = shell_element_gradient(e, moduli[t], xs, Rs, values + static_cast<long long>(t) * kShellElementDofs);
  } else {
    energies[t] = shell_element_energy(e, moduli[t], xs, Rs);
  }
}

// Threads per block of the Hessian kernel: its stack of a block stays within an SM's L1 cache
// (32 x 5 KB), and a few hundred triangles spread over as many SMs as there are blocks.
constexpr int kHessianThreads = 32;

}  // namespace

void DeviceShells::energy(const double* x, const double* q, const VectorOps& ops) {
  if (empty()) return;
  k_shell_elements<ElementOutput::energy><<<grid(count()), kThreads, 0, ops.stream()>>>(
      count(), m_elements.data(), m_moduli.data(), x, q, energies(), nullptr, nullptr);
  check();
  energy_sum(ops);
}

void DeviceShells::add_gradient(const double* x, const double* q, double* g, const VectorOps& ops) {
  if (empty()) return;
  k_shell_elements<ElementOutput::gradient><<<grid(count()), kThreads, 0, ops.stream()>>>(
      count(), m_elements.data(), m_moduli.data(), x, q, energies(), values(), nullptr);
  check();
  gather(g, ops.stream());
  energy_sum(ops);
}

void DeviceShells::prepare(const double* x, const double* q, cudaStream_t stream) {
  if (empty()) return;
  k_shell_elements<ElementOutput::hessian>
      <<<(count() + kHessianThreads - 1) / kHessianThreads, kHessianThreads, 0, stream>>>(
          count(), m_elements.data(), m_moduli.data(), x, q, energies(), nullptr, hessians());
  check();
}

}  // namespace fascia::gpu
