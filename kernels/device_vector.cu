#include "device_vector.hpp"

#include "device_vector.cuh"

#include <cmath>

namespace fascia::gpu {
namespace {

// partials[b] = sum of x_k y_k over block b's stride (y null: sum of x_k).
__global__ void k_dot_partials(long long n, const double* x, const double* y, double* partials) {
  __shared__ double shared[1][kReduceThreads];
  double s[1] = {0.0};
  for (long long k = blockIdx.x * static_cast<long long>(kReduceThreads) + threadIdx.x; k < n;
       k += static_cast<long long>(kReduceBlocks) * kReduceThreads)
    s[0] += y ? x[k] * y[k] : x[k];
  block_sum<1>(s, shared);
  if (threadIdx.x == 0) partials[blockIdx.x] = s[0];
}

// out[0] = sum of the kReduceBlocks partials (one block).
__global__ void k_sum_partials(const double* partials, double* out) {
  __shared__ double shared[1][kReduceThreads];
  double s[1] = {0.0};
  for (int b = threadIdx.x; b < kReduceBlocks; b += kReduceThreads) s[0] += partials[b];
  block_sum<1>(s, shared);
  if (threadIdx.x == 0) out[0] = s[0];
}

__global__ void k_fill(long long n, double value, double* x) {
  for (long long k = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; k < n;
       k += static_cast<long long>(gridDim.x) * blockDim.x)
    x[k] = value;
}

// y += a x
__global__ void k_axpy(long long n, double a, const double* x, double* y) {
  for (long long k = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; k < n;
       k += static_cast<long long>(gridDim.x) * blockDim.x)
    y[k] += a * x[k];
}

// y = x + a y
__global__ void k_xpay(long long n, const double* x, double a, double* y) {
  for (long long k = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; k < n;
       k += static_cast<long long>(gridDim.x) * blockDim.x)
    y[k] = x[k] + a * y[k];
}

// y = s x where not fixed, 0 where fixed (fixed may be null).
__global__ void k_scale_project(long long n, double s, const double* x, const std::uint8_t* fixed, double* y) {
  for (long long k = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; k < n;
       k += static_cast<long long>(gridDim.x) * blockDim.x)
    y[k] = fixed && fixed[k] ? 0.0 : s * x[k];
}

// y_i = B_i x_i per frame (6x6 row-major blocks).
__global__ void k_block_apply(int frames, const double* blocks, const double* x, double* y) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= frames) return;
  double xi[6];
  for (int c = 0; c < 6; ++c) xi[c] = x[6 * i + c];
  for (int r = 0; r < 6; ++r) {
    double s = 0;
    for (int c = 0; c < 6; ++c) s += blocks[36 * i + 6 * r + c] * xi[c];
    y[6 * i + r] = s;
  }
}

// x = a x
__global__ void k_scale(long long n, double a, double* x) {
  for (long long k = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; k < n;
       k += static_cast<long long>(gridDim.x) * blockDim.x)
    x[k] *= a;
}

void check() { FASCIA_CUDA(cudaGetLastError()); }

}  // namespace

DeviceVector::~DeviceVector() { release(); }

DeviceVector::DeviceVector(DeviceVector&& o) noexcept : m_data(o.m_data), m_size(o.m_size), m_stream(o.m_stream) {
  o.m_data = nullptr;
  o.m_size = 0;
}

DeviceVector& DeviceVector::operator=(DeviceVector&& o) noexcept {
  if (this != &o) {
    release();
    m_data = o.m_data;
    m_size = o.m_size;
    m_stream = o.m_stream;
    o.m_data = nullptr;
    o.m_size = 0;
  }
  return *this;
}

void DeviceVector::resize(long long n, cudaStream_t stream) {
  if (n == m_size && stream == m_stream) return;
  release();
  m_stream = stream;
  if (n > 0) FASCIA_CUDA(cudaMallocAsync(reinterpret_cast<void**>(&m_data), n * sizeof(double), stream));
  m_size = n;
}

void DeviceVector::release() {
  if (m_data) cudaFreeAsync(m_data, m_stream);
  m_data = nullptr;
  m_size = 0;
}

VectorOps::VectorOps(cudaStream_t stream) : m_stream(stream) {
  m_partials.resize(kReduceBlocks);
  m_result.resize(1);
  FASCIA_CUDA(cudaMallocHost(&m_host, sizeof(double)));
}

VectorOps::~VectorOps() { cudaFreeHost(m_host); }

void VectorOps::copy(const double* x, double* y, long long n) const { convert_async(x, y, n, m_stream); }

void VectorOps::fill(double* x, double value, long long n) const {
  if (n <= 0) return;
  k_fill<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, value, x);
  check();
}

void VectorOps::axpy(double a, const double* x, double* y, long long n) const {
  if (n <= 0) return;
  k_axpy<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, a, x, y);
  check();
}

void VectorOps::xpay(const double* x, double a, double* y, long long n) const {
  if (n <= 0) return;
  k_xpay<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, x, a, y);
  check();
}

void VectorOps::scale(double a, double* x, long long n) const {
  if (n <= 0) return;
  k_scale<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, a, x);
  check();
}

void VectorOps::project(double* x, const std::uint8_t* fixed, long long n) const {
  if (n <= 0 || !fixed) return;
  k_scale_project<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, 1.0, x, fixed, x);
  check();
}

void VectorOps::block_apply(const double* blocks, const double* x, double* y, int frames) const {
  if (frames <= 0) return;
  k_block_apply<<<vector_grid(frames), kVectorThreads, 0, m_stream>>>(frames, blocks, x, y);
  check();
}

double VectorOps::dot(const double* x, const double* y, long long n) const {
  k_dot_partials<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(n, x, y, m_partials.data());
  check();
  return finish();
}

double VectorOps::finish() const {
  k_sum_partials<<<1, kReduceThreads, 0, m_stream>>>(m_partials.data(), m_result.data());
  check();
  FASCIA_CUDA(cudaMemcpyAsync(m_host, m_result.data(), sizeof(double), cudaMemcpyDeviceToHost, m_stream));
  FASCIA_CUDA(cudaStreamSynchronize(m_stream));
  return *m_host;
}

double DeviceVectorOps::norm(const Vector& x) const { return std::sqrt(dot(x, x)); }

}  // namespace fascia::gpu
