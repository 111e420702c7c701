#include "device_vector.hpp"

#include "device_vector.cuh"

namespace fascia::gpu {
namespace {

// partials[b] = sum of x_k y_k over the block's stride (y null: sum of x; fixed non-null: the
// free entries only).
__global__ void k_dot_partials(long long n, const double* x, const double* y, const std::uint8_t* fixed,
                               double* partials) {
  __shared__ double shared[1][kReduceThreads];
  double s[1] = {0.0};
  for (long long k = blockIdx.x * static_cast<long long>(kReduceThreads) + threadIdx.x; k < n;
       k += static_cast<long long>(kReduceBlocks) * kReduceThreads) {
    if (fixed && fixed[k]) continue;
    s[0] += y ? x[k] * y[k] : x[k];
  }
  block_sum<1>(s, shared);
  if (threadIdx.x == 0) partials[blockIdx.x] = s[0];
}

// out[w] = sum of partials[w * kReduceBlocks + b] over b, for w < width (one block).
__global__ void k_sum_partials(const double* partials, int width, double* out) {
  __shared__ double shared[2][kReduceThreads];
  double s[2] = {0.0, 0.0};
  for (int w = 0; w < width; ++w)
    for (int b = threadIdx.x; b < kReduceBlocks; b += kReduceThreads) s[w] += partials[w * kReduceBlocks + b];
  block_sum<2>(s, shared);
  if (threadIdx.x == 0)
    for (int w = 0; w < width; ++w) out[w] = s[w];
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

// One PCG update over the free DOFs, fused with the preconditioner and both reductions:
//   x += alpha p, r -= alpha Hp, z = P^{-1} r (projected; z = r without P), and the partial
// sums of r.r (partials[b]) and r.z (partials[kReduceBlocks + b]) of block b of the fixed grid.
// One thread per frame; fixed DOFs keep r = z = 0.
__global__ void k_cg_update(int n, double alpha, const double* p, const double* hp, const double* minv,
                            const std::uint8_t* fixed, double* x, double* r, double* z, double* partials) {
  __shared__ double shared[2][kReduceThreads];
  double sums[2] = {0.0, 0.0};
  for (int i = blockIdx.x * kReduceThreads + threadIdx.x; i < n; i += kReduceBlocks * kReduceThreads) {
    double ri[6];
    for (int a = 0; a < 6; ++a) {
      const int k = 6 * i + a;
      x[k] += alpha * p[k];
      ri[a] = fixed[k] ? 0.0 : r[k] - alpha * hp[k];
      r[k] = ri[a];
      sums[0] += ri[a] * ri[a];
    }
    for (int a = 0; a < 6; ++a) {
      double s = ri[a];
      if (minv) {
        s = 0;
        for (int c = 0; c < 6; ++c) s += minv[36 * i + 6 * a + c] * ri[c];
      }
      if (fixed[6 * i + a]) s = 0;
      z[6 * i + a] = s;
      sums[1] += ri[a] * s;
    }
  }
  block_sum<2>(sums, shared);
  if (threadIdx.x == 0) {
    partials[blockIdx.x] = sums[0];
    partials[kReduceBlocks + blockIdx.x] = sums[1];
  }
}

void check() { FASCIA_CUDA(cudaGetLastError()); }

}  // namespace

VectorOps::VectorOps(cudaStream_t stream) : m_stream(stream) {
  m_partials.resize(2 * kReduceBlocks);
  m_result.resize(2);
  FASCIA_CUDA(cudaMallocHost(&m_host, 2 * sizeof(double)));
}

VectorOps::~VectorOps() { cudaFreeHost(m_host); }

void VectorOps::copy(const double* x, double* y, long long n) { convert_async(x, y, n, m_stream); }

void VectorOps::fill(double* x, double value, long long n) {
  if (n <= 0) return;
  k_fill<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, value, x);
  check();
}

void VectorOps::axpy(double a, const double* x, double* y, long long n) {
  if (n <= 0) return;
  k_axpy<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, a, x, y);
  check();
}

void VectorOps::xpay(const double* x, double a, double* y, long long n) {
  if (n <= 0) return;
  k_xpay<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, x, a, y);
  check();
}

void VectorOps::scale_project(double s, const double* x, const std::uint8_t* fixed, double* y, long long n) {
  if (n <= 0) return;
  k_scale_project<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, s, x, fixed, y);
  check();
}

double VectorOps::dot(const double* x, const double* y, long long n, const std::uint8_t* fixed) {
  k_dot_partials<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(n, x, y, fixed, m_partials.data());
  check();
  return finish(1)[0];
}

const double* VectorOps::finish(int width) {
  k_sum_partials<<<1, kReduceThreads, 0, m_stream>>>(m_partials.data(), width, m_result.data());
  check();
  FASCIA_CUDA(cudaMemcpyAsync(m_host, m_result.data(), width * sizeof(double), cudaMemcpyDeviceToHost, m_stream));
  FASCIA_CUDA(cudaStreamSynchronize(m_stream));
  return m_host;
}

std::pair<double, double> VectorOps::cg_update(int frames, double alpha, const double* p, const double* hp,
                                              const double* minv, const std::uint8_t* fixed, double* x, double* r,
                                              double* z) {
  k_cg_update<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(frames, alpha, p, hp, minv, fixed, x, r, z,
                                                              m_partials.data());
  check();
  const double* s = finish(2);
  return {s[0], s[1]};
}

}  // namespace fascia::gpu
