// Device-side pieces of the vector operations (device_vector.hpp) that other kernels share: the
// fixed reduction grid and its block sum, and element-type conversion between device arrays.
#pragma once

#include "device_buffers.cuh"

#include <algorithm>
#include <cstdint>
#include <type_traits>

namespace fascia::gpu {

// A fixed reduction grid: enough blocks to fill an H100/H200 with one wave at 2 blocks per SM,
// and a fixed size so that the summation order is the same on every device.
constexpr int kReduceBlocks = 264;
constexpr int kReduceThreads = 256;
constexpr int kVectorThreads = 256;

inline int vector_grid(long long n) {
  return static_cast<int>(std::max<long long>(1, std::min<long long>((n + kVectorThreads - 1) / kVectorThreads, 65535)));
}

// Sums `values` of this thread block (blockDim.x == kReduceThreads) in a fixed tree; the result
// is valid in thread 0.
template <int Width>
__device__ inline void block_sum(double (&values)[Width], double (*shared)[kReduceThreads]) {
  for (int w = 0; w < Width; ++w) shared[w][threadIdx.x] = values[w];
  __syncthreads();
  for (int stride = kReduceThreads / 2; stride > 0; stride /= 2) {
    if (static_cast<int>(threadIdx.x) < stride)
      for (int w = 0; w < Width; ++w) shared[w][threadIdx.x] += shared[w][threadIdx.x + stride];
    __syncthreads();
  }
  for (int w = 0; w < Width; ++w) values[w] = shared[w][0];
}

template <class From, class To>
__global__ void k_convert(long long n, const From* x, To* y) {
  for (long long k = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; k < n;
       k += static_cast<long long>(gridDim.x) * blockDim.x)
    y[k] = static_cast<To>(x[k]);
}

// y = x, converting the element type (a plain copy where the types agree).
template <class From, class To>
void convert_async(const From* x, To* y, long long n, cudaStream_t stream) {
  if (n <= 0) return;
  if constexpr (std::is_same_v<From, To>) {
    FASCIA_CUDA(cudaMemcpyAsync(y, x, n * sizeof(To), cudaMemcpyDeviceToDevice, stream));
  } else {
    k_convert<From, To><<<vector_grid(n), kVectorThreads, 0, stream>>>(n, x, y);
    FASCIA_CUDA(cudaGetLastError());
  }
}

}  // namespace fascia::gpu
