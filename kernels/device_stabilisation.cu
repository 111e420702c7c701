#include "device_stabilisation.hpp"

#include "core/rotation.hpp"
#include "mechanics/rotation_stabilisation.hpp"

#include <algorithm>

namespace fascia::gpu {
namespace {

constexpr int kThreads = 128;
int grid(int n) { return std::max(1, (n + kThreads - 1) / kThreads); }
void check() { FASCIA_CUDA(cudaGetLastError()); }

// [E][2] the edges' frames.
std::vector<int> edge_nodes(const std::vector<EdgeTwist>& edges) {
  std::vector<int> nodes;
  for (const EdgeTwist& e : edges) nodes.insert(nodes.end(), e.nodes, e.nodes + 2);
  return nodes;
}

// What k_edge_twists evaluates per edge besides its energy.
enum class EdgeOutput { energy, gradient, hessian };

// Per edge: its energy, and its gradient [12] into `values` or its Hessian [12][12] into
// `hessians`, over the nodes' [dx, dr] (the translational entries zero).
template <EdgeOutput Output>
__global__ void k_edge_twists(int count, const EdgeTwist* edges, const double* q, double* energies, double* values,
                              double* hessians) {
  const int e = blockIdx.x * blockDim.x + threadIdx.x;
  if (e >= count) return;
  const EdgeTwist edge = edges[e];
  const Mat3 Ri = rotation_matrix(load_quat(q + 4 * edge.nodes[0]));
  const Mat3 Rj = rotation_matrix(load_quat(q + 4 * edge.nodes[1]));
  if constexpr (Output == EdgeOutput::energy) {
    energies[e] = edge_twist_energy(edge, Ri, Rj);
    return;
  } else {
    const EdgeTwistTerm t = edge_twist_term(edge, Ri, Rj, Output == EdgeOutput::hessian);
    energies[e] = t.energy;
    // DOF a (0..5) of the edge is row 6 (a / 3) + 3 + a % 3 of the element's 12.
    auto row = [](int a) { return 6 * (a / 3) + 3 + a % 3; };
    if constexpr (Output == EdgeOutput::gradient) {
      double* g = values + 12LL * e;
      for (int r = 0; r < 12; ++r) g[r] = 0;
      for (int a = 0; a < kEdgeTwistDofs; ++a) g[row(a)] = t.gradient[a];
    } else {
      double* H = hessians + 144LL * e;
      for (int k = 0; k < 144; ++k) H[k] = 0;
      for (int a = 0; a < kEdgeTwistDofs; ++a)
        for (int b = 0; b < kEdgeTwistDofs; ++b) H[12 * row(a) + row(b)] = t.hessian[a][b];
    }
  }
}

}  // namespace

DeviceStabilisation::DeviceStabilisation(const Model& model) : DeviceStabilisation(RotationStabilisation(model).edges()) {}

DeviceStabilisation::DeviceStabilisation(const std::vector<EdgeTwist>& edges)
    : DeviceElementTerms(2, edge_nodes(edges)) {
  if (!empty()) m_twists.upload(edges);
}

void DeviceStabilisation::energy(const double* q, const VectorOps& ops) {
  if (empty()) return;
  k_edge_twists<EdgeOutput::energy><<<grid(count()), kThreads, 0, ops.stream()>>>(count(), m_twists.data(), q,
                                                                                 energies(), nullptr, nullptr);
  check();
  energy_sum(ops);
}

void DeviceStabilisation::add_gradient(const double* q, double* g, const VectorOps& ops) {
  if (empty()) return;
  k_edge_twists<EdgeOutput::gradient><<<grid(count()), kThreads, 0, ops.stream()>>>(
      count(), m_twists.data(), q, energies(), values(), nullptr);
  check();
  gather(g, ops.stream());
  energy_sum(ops);
}

void DeviceStabilisation::prepare(const double* q, cudaStream_t stream) {
  if (empty()) return;
  k_edge_twists<EdgeOutput::hessian><<<grid(count()), kThreads, 0, stream>>>(count(), m_twists.data(), q,
                                                                            energies(), nullptr,
                                                                            hessians());
  check();
}

}  // namespace fascia::gpu
