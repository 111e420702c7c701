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

// values_t = H_t d_t [18] per triangle, one thread per triangle and row: the 18 threads of a
// triangle read its Hessian's rows side by side (a thread per triangle would read 2.6 KB alone
// and leave most of the device idle on a few hundred triangles).
__global__ void k_shell_products(int count, const ShellElementRest* elements, const double* hessians, const double* d,
                                 double* values) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  const long long t = i / kShellElementDofs;
  const int r = static_cast<int>(i % kShellElementDofs);
  if (t >= count) return;
  const ShellElementRest& e = elements[t];
  const double* H = hessians + t * kShellElementDofs * kShellElementDofs + kShellElementDofs * r;
  double s = 0;
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 6; ++c) s += H[6 * k + c] * d[6 * e.nodes[k] + c];
  values[t * kShellElementDofs + r] = s;
}

// out_i += sum of its entries' 6 values, per frame in entry order.
__global__ void k_shell_gather(int frames, const int* frame_ids, const int* offsets, const int* entries,
                               const double* values, double* out) {
  const int f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= frames) return;
  double s[6] = {0, 0, 0, 0, 0, 0};
  for (int e = offsets[f]; e < offsets[f + 1]; ++e) {
    const int entry = entries[e];  // 3 t + node: values at 18 t + 6 node = 6 entry
    for (int c = 0; c < 6; ++c) s[c] += values[6LL * entry + c];
  }
  double* o = out + 6 * frame_ids[f];
  for (int c = 0; c < 6; ++c) o[c] += s[c];
}

// blocks_i += the node's 6x6 diagonal block of each of its triangles' Hessians.
__global__ void k_shell_blocks(int frames, const int* frame_ids, const int* offsets, const int* entries,
                               const double* hessians, double* blocks) {
  const int f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= frames) return;
  double* B = blocks + 36 * frame_ids[f];
  for (int e = offsets[f]; e < offsets[f + 1]; ++e) {
    const int t = entries[e] / 3, node = entries[e] % 3;
    const double* H = hessians + static_cast<long long>(t) * kShellElementDofs * kShellElementDofs;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) B[6 * r + c] += H[kShellElementDofs * (6 * node + r) + 6 * node + c];
  }
}

// blocks[p] += sum of its terms' node blocks H_t(node_a, node_b), block p = block_ids[k]; one thread
// per block entry (k, r, c), its terms in list order.
__global__ void k_shell_tangent_blocks(int touched, const int* block_ids, const int* offsets, const int* terms,
                                       const double* hessians, double* blocks) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  const int k = static_cast<int>(i / 36), e = static_cast<int>(i % 36), r = e / 6, c = e % 6;
  if (k >= touched) return;
  double s = 0;
  for (int j = offsets[k]; j < offsets[k + 1]; ++j) {
    const int term = terms[j], t = term / 9, a = term / 3 % 3, b = term % 3;
    s += hessians[static_cast<long long>(t) * kShellElementDofs * kShellElementDofs +
                  kShellElementDofs * (6 * a + r) + 6 * b + c];
  }
  blocks[36LL * block_ids[k] + e] += s;
}

}  // namespace

double DeviceShells::energy(const double* x, const double* q, const VectorOps& ops) {
  if (empty()) return 0.0;
  k_shell_elements<ElementOutput::energy><<<grid(m_triangles), kThreads, 0, ops.stream()>>>(
      m_triangles, m_elements.data(), m_moduli.data(), x, q, m_energies.data(), nullptr, nullptr);
  check();
  return ops.dot(m_energies.data(), nullptr, m_triangles);
}

double DeviceShells::add_gradient(const double* x, const double* q, double* g, const VectorOps& ops) {
  if (empty()) return 0.0;
  k_shell_elements<ElementOutput::gradient><<<grid(m_triangles), kThreads, 0, ops.stream()>>>(
      m_triangles, m_elements.data(), m_moduli.data(), x, q, m_energies.data(), m_values.data(), nullptr);
  check();
  k_shell_gather<<<grid(m_frames), kThreads, 0, ops.stream()>>>(m_frames, m_frame_ids.data(), m_offsets.data(),
                                                                m_entries.data(), m_values.data(), g);
  check();
  return ops.dot(m_energies.data(), nullptr, m_triangles);
}

void DeviceShells::prepare(const double* x, const double* q, cudaStream_t stream) {
  if (empty()) return;
  k_shell_elements<ElementOutput::hessian>
      <<<(m_triangles + kHessianThreads - 1) / kHessianThreads, kHessianThreads, 0, stream>>>(
          m_triangles, m_elements.data(), m_moduli.data(), x, q, m_energies.data(), nullptr, m_hessians.data());
  check();
}

void DeviceShells::add_tangent(const double* d, double* out, cudaStream_t stream) {
  if (empty()) return;
  k_shell_products<<<grid(m_triangles * kShellElementDofs), kThreads, 0, stream>>>(m_triangles, m_elements.data(), m_hessians.data(), d,
                                                               m_values.data());
  check();
  k_shell_gather<<<grid(m_frames), kThreads, 0, stream>>>(m_frames, m_frame_ids.data(), m_offsets.data(),
                                                          m_entries.data(), m_values.data(), out);
  check();
}

void DeviceShells::add_tangent_blocks(double* blocks, cudaStream_t stream) const {
  if (m_touched_blocks == 0) return;
  k_shell_tangent_blocks<<<grid(36 * m_touched_blocks), kThreads, 0, stream>>>(
      m_touched_blocks, m_block_ids.data(), m_block_offsets.data(), m_block_terms.data(), m_hessians.data(), blocks);
  check();
}

void DeviceShells::add_diagonal_blocks(double* blocks, cudaStream_t stream) const {
  if (empty()) return;
  k_shell_blocks<<<grid(m_frames), kThreads, 0, stream>>>(m_frames, m_frame_ids.data(), m_offsets.data(),
                                                          m_entries.data(), m_hessians.data(), blocks);
  check();
}

}  // namespace fascia::gpu
