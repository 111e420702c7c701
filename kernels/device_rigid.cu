#include "device_rigid.hpp"

#include "core/rotation.hpp"

#include <algorithm>

namespace fascia::gpu {
namespace {

constexpr int kThreads = 128;
int grid(int n) { return std::max(1, (n + kThreads - 1) / kThreads); }
void check() { FASCIA_CUDA(cudaGetLastError()); }

// (f r^T + r f^T)/2 - (f . r) I, rigid_mapping.hpp.
__device__ Mat3 geometric_block(const Vec3& f, const Vec3& r) {
  return 0.5 * (outer(f, r) + outer(r, f)) - dot(f, r) * identity3();
}

__global__ void k_sync(int count, const int* mapped, const int* parent, const double* rest, double* x, double* q) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= count) return;
  const int a = mapped[k], b = parent[k];
  const Mat3 R = rotation_matrix(load_quat(q + 4 * b));
  store3(x + 3 * a, load3(x + 3 * b) + R * load3(rest + 3 * k));
  for (int c = 0; c < 4; ++c) q[4 * a + c] = q[4 * b + c];
}

__global__ void k_offsets(int count, const int* mapped, const int* parent, const double* x, double* offsets) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= count) return;
  store3(offsets + 3 * k, load3(x + 3 * mapped[k]) - load3(x + 3 * parent[k]));
}

__global__ void k_forces(int count, const int* mapped, const double* g, double* forces) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= count) return;
  store3(forces + 3 * k, load3(g + 6 * mapped[k]));
}

// v_b += J_a^T v_a, v_a = 0 for the attached frames of body j in ascending k, as RigidMapping::reduce.
__device__ void reduce_body(int j, const int* body, const int* offsets, const int* entries, const int* mapped,
                            const double* r_all, double* v) {
  double* vb = v + 6 * body[j];
  for (int e = offsets[j]; e < offsets[j + 1]; ++e) {
    const int k = entries[e];
    double* va = v + 6 * mapped[k];
    const Vec3 f = load3(va), r = load3(r_all + 3 * k);
    const Vec3 t = cross(r, f);  // J^T [f; t_a] = [f; t_a + r x f]
    for (int c = 0; c < 3; ++c) vb[c] += va[c];
    vb[3] += va[3] + t.x, vb[4] += va[4] + t.y, vb[5] += va[5] + t.z;
    for (int c = 0; c < 6; ++c) va[c] = 0;
  }
}

// One thread per body.
__global__ void k_reduce(int bodies, const int* body, const int* offsets, const int* entries, const int* mapped,
                         const double* r_all, double* v) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= bodies) return;
  reduce_body(j, body, offsets, entries, mapped, r_all, v);
}

// One thread per body: the reduction, then out_b(rotation) += G_a d_b(rotation) over its frames.
__global__ void k_reduce_product(int bodies, const int* body, const int* offsets, const int* entries,
                                 const int* mapped, const double* forces, const double* r_all, const double* d,
                                 double* out) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= bodies) return;
  reduce_body(j, body, offsets, entries, mapped, r_all, out);
  const int b = body[j];
  const Vec3 w = load3(d + 6 * b + 3);
  for (int e = offsets[j]; e < offsets[j + 1]; ++e) {
    const int k = entries[e];
    const Vec3 y = geometric_block(load3(forces + 3 * k), load3(r_all + 3 * k)) * w;
    out[6 * b + 3] += y.x, out[6 * b + 4] += y.y, out[6 * b + 5] += y.z;
  }
}

// One thread per frame: out_i = d_i, or J_a d_b for an attached frame (u - [r]x w, w).
__global__ void k_expand(int frames, const int* slot, const int* parent, const double* r_all, const double* d,
                         double* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= frames) return;
  const int k = slot[i];
  double* o = out + 6 * i;
  if (k < 0) {
    for (int c = 0; c < 6; ++c) o[c] = d[6 * i + c];
    return;
  }
  const double* db = d + 6 * parent[k];
  const Vec3 u = load3(db), w = load3(db + 3), r = load3(r_all + 3 * k);
  const Vec3 x = u + cross(w, r);  // u - [r]x w
  o[0] = x.x, o[1] = x.y, o[2] = x.z, o[3] = w.x, o[4] = w.y, o[5] = w.z;
}

__global__ void k_reduce_blocks(int bodies, const int* body, const int* offsets, const int* entries,
                                const int* mapped, const double* forces, const double* r_all, double* blocks) {
  const int j = blockIdx.x * blockDim.x + threadIdx.x;
  if (j >= bodies) return;
  double* Bb = blocks + 36 * body[j];
  for (int e = offsets[j]; e < offsets[j + 1]; ++e) {
    const int k = entries[e];
    const Vec3 r = load3(r_all + 3 * k);
    double J[36] = {0};
    for (int c = 0; c < 6; ++c) J[6 * c + c] = 1;
    const Mat3 mr = -1.0 * skew(r);
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 3; ++c) J[6 * i + 3 + c] = mr.m[i][c];
    const double* Ba = blocks + 36 * mapped[k];
    double BJ[36] = {0};
    for (int i = 0; i < 6; ++i)
      for (int c = 0; c < 6; ++c)
        for (int l = 0; l < 6; ++l) BJ[6 * i + c] += Ba[6 * i + l] * J[6 * l + c];
    for (int i = 0; i < 6; ++i)
      for (int c = 0; c < 6; ++c)
        for (int l = 0; l < 6; ++l) Bb[6 * i + c] += J[6 * l + i] * BJ[6 * l + c];
    const Mat3 G = geometric_block(load3(forces + 3 * k), r);
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 3; ++c) Bb[6 * (3 + i) + 3 + c] += G.m[i][c];
  }
}

__global__ void k_identity_blocks(int count, const int* mapped, double* blocks) {
  const int k = blockIdx.x * blockDim.x + threadIdx.x;
  if (k >= count) return;
  double* B = blocks + 36 * mapped[k];
  for (int i = 0; i < 36; ++i) B[i] = i % 7 == 0 ? 1.0 : 0.0;
}

}  // namespace

void DeviceRigidMapping::sync(double* x, double* q, cudaStream_t stream) const {
  if (!m_count) return;
  k_sync<<<grid(m_count), kThreads, 0, stream>>>(m_count, m_mapped.data(), m_parent.data(), m_rest_offsets.data(), x, q);
  check();
}

void DeviceRigidMapping::set_state(const double* x, cudaStream_t stream) {
  if (!m_count) return;
  k_offsets<<<grid(m_count), kThreads, 0, stream>>>(m_count, m_mapped.data(), m_parent.data(), x, m_offsets.data());
  check();
}

void DeviceRigidMapping::set_geometric(const double* gradient, cudaStream_t stream) {
  if (!m_count) return;
  k_forces<<<grid(m_count), kThreads, 0, stream>>>(m_count, m_mapped.data(), gradient, m_forces.data());
  check();
}

void DeviceRigidMapping::reduce(double* v, cudaStream_t stream) const {
  if (!m_count) return;
  k_reduce<<<grid(m_bodies), kThreads, 0, stream>>>(m_bodies, m_body.data(), m_body_offsets.data(),
                                                    m_body_entries.data(), m_mapped.data(), m_offsets.data(), v);
  check();
}

void DeviceRigidMapping::reduce_product(const double* d, double* out, cudaStream_t stream) const {
  if (!m_count) return;
  k_reduce_product<<<grid(m_bodies), kThreads, 0, stream>>>(m_bodies, m_body.data(), m_body_offsets.data(),
                                                            m_body_entries.data(), m_mapped.data(), m_forces.data(),
                                                            m_offsets.data(), d, out);
  check();
}

void DeviceRigidMapping::expand(const double* d, double* out, cudaStream_t stream) const {
  if (!m_count) return;
  k_expand<<<grid(m_frames), kThreads, 0, stream>>>(m_frames, m_slot.data(), m_parent.data(), m_offsets.data(), d, out);
  check();
}

void DeviceRigidMapping::reduce_diagonal_blocks(double* blocks, cudaStream_t stream) const {
  if (!m_count) return;
  k_reduce_blocks<<<grid(m_bodies), kThreads, 0, stream>>>(m_bodies, m_body.data(), m_body_offsets.data(),
                                                           m_body_entries.data(), m_mapped.data(), m_forces.data(),
                                                           m_offsets.data(), blocks);
  check();
  k_identity_blocks<<<grid(m_count), kThreads, 0, stream>>>(m_count, m_mapped.data(), blocks);
  check();
}

}  // namespace fascia::gpu
