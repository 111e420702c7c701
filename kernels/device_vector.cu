#include "device_vector.hpp"

#include "device_vector.cuh"

#include <cmath>
#include <functional>
#include <stdexcept>

namespace fascia::gpu {
namespace {

// Block b's partial of x^T y (y null: of x) into partials[b]: block b takes k = b kReduceThreads
// + t, + kReduceBlocks kReduceThreads, ... and sums its values in the fixed tree of block_sum.
__device__ void dot_partial(long long n, const double* x, const double* y, double* partials) {
  __shared__ double shared[1][kReduceThreads];
  double s[1] = {0.0};
  for (long long k = blockIdx.x * static_cast<long long>(kReduceThreads) + threadIdx.x; k < n;
       k += static_cast<long long>(kReduceBlocks) * kReduceThreads)
    s[0] += y ? x[k] * y[k] : x[k];
  block_sum<1>(s, shared);
  if (threadIdx.x == 0) partials[blockIdx.x] = s[0];
}

// The sum of the kReduceBlocks partials in a fixed tree, valid in thread 0. Read past the L1
// cache: other blocks of the same kernel may have written them (last_block).
__device__ double sum_partials(const double* partials) {
  __shared__ double shared[1][kReduceThreads];
  double s[1] = {0.0};
  for (int b = threadIdx.x; b < kReduceBlocks; b += kReduceThreads) s[0] += __ldcg(partials + b);
  block_sum<1>(s, shared);
  return s[0];
}

// out[0] = sum of the kReduceBlocks partials (one block).
__global__ void k_sum_partials(const double* partials, double* out) {
  const double s = sum_partials(partials);
  if (threadIdx.x == 0) out[0] = s;
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

// y_i = B_i x_i per frame (6x6 row-major blocks), or y_i += B_i x_i where add.
__global__ void k_block_apply(int frames, const double* blocks, const double* x, bool add, double* y) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= frames) return;
  double xi[6];
  for (int c = 0; c < 6; ++c) xi[c] = x[6 * i + c];
  for (int r = 0; r < 6; ++r) {
    double s = add ? y[6 * i + r] : 0.0;
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

// What cg_step's update does this iteration.
enum CgMode : int { kCgIdle = 0, kCgUpdate = 1, kCgFirstBreakdown = 2, kCgBreakdown = 3 };

struct VectorOps::CgState {
  double rho, alpha, beta, b_norm, tolerance, relative_residual;
  int iterations, stopped, negative_curvature, mode;
  int identity;  // z is r (plain CG): k_cg_update forms rho' = r^T r, cg_direction only updates p
};

namespace {

// Whether this block is the grid's last to have written its partial (each block's thread 0
// fences its partial, then counts itself in): that block then sums the partials in the fixed
// tree, so that one kernel forms a reduction's scalar, and sets the counter back to zero for the
// next kernel (CUDA C++ Programming Guide, the memory fence functions' example).
__device__ bool last_block(unsigned* counter) {
  __shared__ bool last;
  if (threadIdx.x == 0) {
    __threadfence();
    last = atomicAdd(counter, 1u) == gridDim.x - 1;
    if (last) *counter = 0;
  }
  __syncthreads();
  return last;
}

// out[0] = x^T y (y null: sum_k x_k): the partials, then the last block sums them.
__global__ void k_dot(long long n, const double* x, const double* y, double* partials, unsigned* counter, double* out) {
  dot_partial(n, x, y, partials);
  if (!last_block(counter)) return;
  const double s = sum_partials(partials);
  if (threadIdx.x == 0) out[0] = s;
}

// The state of a solve that has just started from r = P b (x = 0): |b| from r^T r, which is also
// plain CG's rho (a preconditioned solve's first k_cg_rho sets its own); stopped where b = 0.
__global__ void k_cg_start(long long n, const double* r, const double* z, double* partials, unsigned* counter,
                           double tolerance, VectorOps::CgState* cg) {
  dot_partial(n, r, r, partials);
  if (!last_block(counter)) return;
  const double rr = sum_partials(partials);
  if (threadIdx.x == 0)
    *cg = VectorOps::CgState{rr, 0, 0, sqrt(rr), tolerance, 0, 0, rr == 0, 0, kCgIdle, r == z};
}

// From c = p^T H p: alpha = rho / c, or the breakdown.
__global__ void k_cg_curvature(long long n, const double* p, const double* hp, double* partials, unsigned* counter,
                               VectorOps::CgState* cg) {
  dot_partial(n, p, hp, partials);
  if (!last_block(counter)) return;
  const double c = sum_partials(partials);
  if (threadIdx.x != 0) return;
  if (cg->stopped) {
    cg->mode = kCgIdle;
  } else if (!(c > 0)) {
    cg->mode = cg->iterations == 0 ? kCgFirstBreakdown : kCgBreakdown;
    cg->stopped = cg->negative_curvature = 1;
  } else {
    cg->alpha = cg->rho / c;
    cg->mode = kCgUpdate;
  }
}

// The update of the mode (x += alpha p, r -= alpha P H p; or x = P z), then |r| / |b| from r^T r
// and the convergence test after an update; with z = r (plain CG), also k_cg_rho's step from
// rho' = r^T r, summed in k_cg_rho's order (dot_partial's), so with the same bits. Every block
// reads the mode before the last one resets it.
__global__ void k_cg_update(long long n, VectorOps::CgState* cg, const double* p, const double* hp, const double* z,
                            const std::uint8_t* fixed, double* x, double* r, double* partials, unsigned* counter) {
  const int mode = cg->mode;
  if (mode == kCgIdle) return;
  const double alpha = cg->alpha;
  __shared__ double shared[1][kReduceThreads];
  double s[1] = {0.0};
  for (long long k = blockIdx.x * static_cast<long long>(kReduceThreads) + threadIdx.x; k < n;
       k += static_cast<long long>(kReduceBlocks) * kReduceThreads) {
    const bool free = !(fixed && fixed[k]);
    if (mode == kCgUpdate) {
      x[k] += alpha * p[k];
      if (free) r[k] -= alpha * hp[k];
    } else if (mode == kCgFirstBreakdown) {
      x[k] = free ? z[k] : 0.0;  // preconditioned steepest descent
    }
    s[0] += r[k] * r[k];
  }
  block_sum<1>(s, shared);
  if (threadIdx.x == 0) partials[blockIdx.x] = s[0];
  if (!last_block(counter)) return;
  const double rr = sum_partials(partials);
  if (threadIdx.x != 0) return;
  cg->relative_residual = sqrt(rr) / cg->b_norm;
  if (mode == kCgUpdate) {
    ++cg->iterations;
    cg->stopped = cg->relative_residual <= cg->tolerance;
    if (cg->identity && !cg->stopped) {
      cg->beta = rr / cg->rho;
      cg->rho = rr;
    }
  }
  cg->mode = kCgIdle;
}

// From rho' = r^T z: beta = rho' / rho, rho = rho'.
__global__ void k_cg_rho(long long n, const double* r, const double* z, double* partials, unsigned* counter,
                         VectorOps::CgState* cg) {
  dot_partial(n, r, z, partials);
  if (!last_block(counter)) return;
  const double rho = sum_partials(partials);
  if (threadIdx.x != 0 || cg->stopped) return;
  cg->beta = cg->iterations > 0 ? rho / cg->rho : 0.0;  // the first direction is P z
  cg->rho = rho;
}

// p = P z + beta p while running.
__global__ void k_cg_xpay(long long n, const VectorOps::CgState* cg, const double* z, const std::uint8_t* fixed,
                          double* p) {
  if (cg->stopped) return;
  const double beta = cg->beta;
  for (long long k = blockIdx.x * static_cast<long long>(blockDim.x) + threadIdx.x; k < n;
       k += static_cast<long long>(gridDim.x) * blockDim.x)
    p[k] = fixed && fixed[k] ? 0.0 : z[k] + beta * p[k];
}

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
  count_device_buffer_bytes(static_cast<long long>(sizeof(double)) * n);
}

void DeviceVector::release() {
  count_device_buffer_bytes(-static_cast<long long>(sizeof(double)) * m_size);
  if (m_data) cudaFreeAsync(m_data, m_stream);
  m_data = nullptr;
  m_size = 0;
}

VectorOps::VectorOps(cudaStream_t stream) : m_stream(stream) {
  m_partials.resize(kReduceBlocks);
  m_pending.resize(kPendingTerms);
  m_counter.resize(1);
  FASCIA_CUDA(cudaMemsetAsync(m_counter.data(), 0, sizeof(unsigned), m_stream));
  FASCIA_CUDA(cudaMallocHost(&m_host, sizeof(double) * kPendingTerms));
  FASCIA_CUDA(cudaMalloc(reinterpret_cast<void**>(&m_cg), sizeof(CgState)));
  FASCIA_CUDA(cudaMallocHost(reinterpret_cast<void**>(&m_cg_host), sizeof(CgState)));
}

VectorOps::~VectorOps() {
  if (m_record) cudaGraphExecDestroy(m_record);
  cudaFreeHost(m_host);
  cudaFree(m_cg);
  cudaFreeHost(m_cg_host);
}

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

void VectorOps::block_apply(const double* blocks, const double* x, double* y, int frames, bool add) const {
  if (frames <= 0) return;
  k_block_apply<<<vector_grid(frames), kVectorThreads, 0, m_stream>>>(frames, blocks, x, add, y);
  check();
}

double VectorOps::dot(const double* x, const double* y, long long n) const {
  if (m_pending_count != 0) throw std::logic_error("VectorOps::dot: terms are pending");
  dot_pending(x, y, n);
  return read_pending();
}

double VectorOps::finish() const {
  if (m_pending_count != 0) throw std::logic_error("VectorOps::finish: terms are pending");
  finish_pending();
  return read_pending();
}

double* VectorOps::next_pending() const {
  if (m_pending_count == kPendingTerms) throw std::logic_error("VectorOps: more pending terms than slots");
  return m_pending.data() + m_pending_count++;
}

void VectorOps::dot_pending(const double* x, const double* y, long long n) const {
  k_dot<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(n, x, y, m_partials.data(), m_counter.data(), next_pending());
  check();
}

void VectorOps::finish_pending() const {
  k_sum_partials<<<1, kReduceThreads, 0, m_stream>>>(m_partials.data(), next_pending());
  check();
}

void VectorOps::copy_pending(const double* value) const {
  FASCIA_CUDA(cudaMemcpyAsync(next_pending(), value, sizeof(double), cudaMemcpyDeviceToDevice, m_stream));
}

double VectorOps::read_pending() const {
  const int count = m_pending_count;
  m_pending_count = 0;
  if (count == 0) return 0.0;
  FASCIA_CUDA(cudaMemcpyAsync(m_host, m_pending.data(), sizeof(double) * count, cudaMemcpyDeviceToHost, m_stream));
  FASCIA_CUDA(cudaStreamSynchronize(m_stream));
  double sum = m_host[0];
  for (int k = 1; k < count; ++k) sum += m_host[k];
  return sum;
}

void VectorOps::cg_start(const double* r, const double* z, long long n, double tolerance) const {
  k_cg_start<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(n, r, z, m_partials.data(), m_counter.data(), tolerance,
                                                              m_cg);
  check();
}

void VectorOps::cg_step(const double* p, const double* hp, const double* z, const std::uint8_t* fixed, double* x,
                        double* r, long long n) const {
  k_cg_curvature<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(n, p, hp, m_partials.data(), m_counter.data(), m_cg);
  k_cg_update<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(n, m_cg, p, hp, z, fixed, x, r, m_partials.data(),
                                                               m_counter.data());
  check();
}

void VectorOps::cg_direction(const double* r, const double* z, const std::uint8_t* fixed, double* p,
                             long long n) const {
  // z = r: k_cg_update has formed rho' (CgState::identity).
  if (r != z)
    k_cg_rho<<<kReduceBlocks, kReduceThreads, 0, m_stream>>>(n, r, z, m_partials.data(), m_counter.data(), m_cg);
  if (n > 0) k_cg_xpay<<<vector_grid(n), kVectorThreads, 0, m_stream>>>(n, m_cg, z, fixed, p);
  check();
}

unsigned long VectorOps::record(const std::function<void()>& body) const {
  cudaGraph_t graph = nullptr;
  FASCIA_CUDA(cudaStreamBeginCapture(m_stream, cudaStreamCaptureModeThreadLocal));
  try {
    body();
  } catch (...) {
    cudaStreamEndCapture(m_stream, &graph);
    if (graph) cudaGraphDestroy(graph);
    throw;
  }
  FASCIA_CUDA(cudaStreamEndCapture(m_stream, &graph));
  // The record is updated in place where the body enqueued the same kinds of work as the last
  // one (the next solve's iterations), else made anew.
  if (m_record) {
    cudaGraphExecUpdateResultInfo info{};
    if (cudaGraphExecUpdate(m_record, graph, &info) != cudaSuccess) {
      (void)cudaGetLastError();
      cudaGraphExecDestroy(m_record);
      m_record = nullptr;
    }
  }
  cudaError_t made = cudaSuccess;
  if (!m_record) made = cudaGraphInstantiate(&m_record, graph, 0);
  cudaGraphDestroy(graph);
  FASCIA_CUDA(made);
  return ++m_generation;
}

void VectorOps::replay(int count) const {
  for (int k = 0; k < count; ++k) FASCIA_CUDA(cudaGraphLaunch(m_record, m_stream));
}

CgStatus VectorOps::cg_status() const {
  FASCIA_CUDA(cudaMemcpyAsync(m_cg_host, m_cg, sizeof(CgState), cudaMemcpyDeviceToHost, m_stream));
  FASCIA_CUDA(cudaStreamSynchronize(m_stream));
  CgStatus s;
  s.iterations = m_cg_host->iterations;
  s.relative_residual = m_cg_host->relative_residual;
  s.stopped = m_cg_host->stopped != 0;
  s.negative_curvature = m_cg_host->negative_curvature != 0;
  return s;
}

double DeviceVectorOps::norm(const Vector& x) const { return std::sqrt(dot(x, x)); }

}  // namespace fascia::gpu
