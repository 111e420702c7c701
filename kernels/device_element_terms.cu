#include "device_element_terms.hpp"

#include "integrate/tangent_probing.hpp"

#include <algorithm>
#include <map>

namespace fascia::gpu {
namespace {

constexpr int kThreads = 128;
unsigned grid(long long n) { return static_cast<unsigned>(std::max(1LL, (n + kThreads - 1) / kThreads)); }
void check() { FASCIA_CUDA(cudaGetLastError()); }

// values_t = H_t d_t [6k] per element, one thread per element and row: the 6k threads of an
// element read its Hessian's rows side by side (a thread per element would read its whole Hessian
// alone and leave most of the device idle on a few hundred elements).
__global__ void k_element_products(int count, int k, const int* nodes, const double* hessians, const double* d,
                                   double* values) {
  const int dofs = 6 * k;
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  const long long t = i / dofs;
  const int r = static_cast<int>(i % dofs);
  if (t >= count) return;
  const double* H = hessians + t * dofs * dofs + static_cast<long long>(dofs) * r;
  double s = 0;
  for (int a = 0; a < k; ++a) {
    const double* da = d + 6LL * nodes[t * k + a];
    for (int c = 0; c < 6; ++c) s += H[6 * a + c] * da[c];
  }
  values[t * dofs + r] = s;
}

// out_i += sum of its entries' 6 values, per frame in entry order.
__global__ void k_element_gather(int frames, const int* frame_ids, const int* offsets, const int* entries,
                                 const double* values, double* out) {
  const int f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= frames) return;
  double s[6] = {0, 0, 0, 0, 0, 0};
  for (int e = offsets[f]; e < offsets[f + 1]; ++e) {
    const long long entry = entries[e];  // k t + node: values at 6k t + 6 node = 6 entry
    for (int c = 0; c < 6; ++c) s[c] += values[6 * entry + c];
  }
  double* o = out + 6LL * frame_ids[f];
  for (int c = 0; c < 6; ++c) o[c] += s[c];
}

// blocks_i += the node's 6x6 diagonal block of each of its elements' Hessians.
__global__ void k_element_diagonal_blocks(int frames, int k, const int* frame_ids, const int* offsets,
                                          const int* entries, const double* hessians, double* blocks) {
  const int f = blockIdx.x * blockDim.x + threadIdx.x;
  if (f >= frames) return;
  const int dofs = 6 * k;
  double* B = blocks + 36LL * frame_ids[f];
  for (int e = offsets[f]; e < offsets[f + 1]; ++e) {
    const int t = entries[e] / k, node = entries[e] % k;
    const double* H = hessians + static_cast<long long>(t) * dofs * dofs;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) B[6 * r + c] += H[dofs * (6 * node + r) + 6 * node + c];
  }
}

// blocks[p] += sum of its terms' node blocks H_t(node_a, node_b), block p = block_ids[q]; one
// thread per block entry (q, r, c), its terms in list order.
__global__ void k_element_tangent_blocks(int touched, int k, const int* block_ids, const int* offsets,
                                         const int* terms, const double* hessians, double* blocks) {
  const long long i = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x;
  const int q = static_cast<int>(i / 36), e = static_cast<int>(i % 36), r = e / 6, c = e % 6;
  if (q >= touched) return;
  const int dofs = 6 * k;
  double s = 0;
  for (int j = offsets[q]; j < offsets[q + 1]; ++j) {
    const int term = terms[j], t = term / (k * k), a = term / k % k, b = term % k;
    s += hessians[static_cast<long long>(t) * dofs * dofs + dofs * (6 * a + r) + 6 * b + c];
  }
  blocks[36LL * block_ids[q] + e] += s;
}

// Host CSR of lists keyed by index: ids, offsets [ids + 1], the lists' items in key order.
void flatten(const std::map<int, std::vector<int>>& lists, std::vector<int>& ids, std::vector<int>& offsets,
             std::vector<int>& items) {
  ids.clear();
  items.clear();
  offsets.assign(1, 0);
  for (const auto& [key, list] : lists) {
    ids.push_back(key);
    items.insert(items.end(), list.begin(), list.end());
    offsets.push_back(static_cast<int>(items.size()));
  }
}

}  // namespace

DeviceElementTerms::DeviceElementTerms(int nodes_per_element, const std::vector<int>& nodes)
    : m_nodes_per_element(nodes_per_element),
      m_elements(static_cast<int>(nodes.size()) / nodes_per_element),
      m_host_nodes(nodes) {
  if (m_elements == 0) return;
  const int k = nodes_per_element;
  std::map<int, std::vector<int>> by_frame;  // frame -> k t + node, ascending t
  for (int t = 0; t < m_elements; ++t)
    for (int a = 0; a < k; ++a) by_frame[nodes[static_cast<size_t>(k) * t + a]].push_back(k * t + a);
  std::vector<int> frames, offsets, entries;
  flatten(by_frame, frames, offsets, entries);
  m_frames = static_cast<int>(frames.size());
  m_nodes.upload(nodes);
  m_frame_ids.upload(frames);
  m_offsets.upload(offsets);
  m_entries.upload(entries);
  const size_t dofs = static_cast<size_t>(element_dofs());
  m_values.resize(static_cast<size_t>(m_elements) * dofs);
  m_energies.resize(static_cast<size_t>(m_elements));
  m_hessians.resize(static_cast<size_t>(m_elements) * dofs * dofs);
}

void DeviceElementTerms::energy_sum(const VectorOps& ops) const {
  if (!empty()) ops.dot_pending(m_energies.data(), nullptr, m_elements);
}

void DeviceElementTerms::gather(double* out, cudaStream_t stream) const {
  if (empty()) return;
  k_element_gather<<<grid(m_frames), kThreads, 0, stream>>>(m_frames, m_frame_ids.data(), m_offsets.data(),
                                                            m_entries.data(), m_values.data(), out);
  check();
}

void DeviceElementTerms::add_tangent(const double* d, double* out, cudaStream_t stream) {
  if (empty()) return;
  k_element_products<<<grid(static_cast<long long>(m_elements) * element_dofs()), kThreads, 0, stream>>>(
      m_elements, m_nodes_per_element, m_nodes.data(), m_hessians.data(), d, m_values.data());
  check();
  gather(out, stream);
}

void DeviceElementTerms::add_diagonal_blocks(double* blocks, cudaStream_t stream) const {
  if (empty()) return;
  k_element_diagonal_blocks<<<grid(m_frames), kThreads, 0, stream>>>(m_frames, m_nodes_per_element, m_frame_ids.data(),
                                                                     m_offsets.data(), m_entries.data(),
                                                                     m_hessians.data(), blocks);
  check();
}

void DeviceElementTerms::set_tangent_blocks(const std::vector<int>& block_offsets, const std::vector<int>& block_frames) {
  m_touched_blocks = 0;
  if (empty()) return;
  const int k = m_nodes_per_element;
  std::map<int, std::vector<int>> by_block;  // block -> k^2 t + k node_a + node_b, ascending t
  for (int t = 0; t < m_elements; ++t)
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b) {
        const int fa = m_host_nodes[static_cast<size_t>(k) * t + a], fb = m_host_nodes[static_cast<size_t>(k) * t + b];
        if (fb > fa) continue;
        const int p = assembled_block(block_offsets.data(), block_frames.data(), fa, fb);
        if (p >= 0) by_block[p].push_back(k * k * t + k * a + b);
      }
  std::vector<int> ids, offsets, terms;
  flatten(by_block, ids, offsets, terms);
  m_touched_blocks = static_cast<int>(ids.size());
  m_block_ids.upload(ids);
  m_block_offsets.upload(offsets);
  m_block_terms.upload(terms);
}

void DeviceElementTerms::add_tangent_blocks(double* blocks, cudaStream_t stream) const {
  if (m_touched_blocks == 0) return;
  k_element_tangent_blocks<<<grid(36LL * m_touched_blocks), kThreads, 0, stream>>>(
      m_touched_blocks, m_nodes_per_element, m_block_ids.data(), m_block_offsets.data(), m_block_terms.data(),
      m_hessians.data(), blocks);
  check();
}

}  // namespace fascia::gpu
