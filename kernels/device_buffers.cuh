// Owning device buffers and CUDA error checks for kernels/.
#pragma once

#include <cuda_runtime.h>

#include <cstddef>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace fascia::gpu {

inline void cuda_check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw std::runtime_error(std::string("CUDA error in ") + what + ": " + cudaGetErrorString(e));
}
#define FASCIA_CUDA(call) ::fascia::gpu::cuda_check((call), #call)

// The device buffers' bytes, counted as they allocate and free (device_memory.hpp).
void count_device_buffer_bytes(long long delta);

// A device array of T, move-only. upload() converts element types (double -> float).
//
// kernels/ enqueues its work on non-blocking streams, which do not wait for the legacy default
// stream that cudaMemcpy and cudaMemset use; and a cudaMemcpy from pageable host memory returns
// once the data is staged, with its copy to the device possibly still queued (CUDA runtime API,
// "API synchronization behavior"). So upload(host) and zero() wait for the legacy stream before
// returning: their data is on the device for any stream's later work. upload(host, stream) is
// ordered on `stream` instead, without a wait: cudaMemcpyAsync from pageable memory (the host
// arrays here are; pinned memory would have to outlive the copy) stages the data before it
// returns, so the host array may change at once. download() waits for its copy but not for the
// streams: the caller synchronises the stream that wrote the buffer first.
template <class T>
class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  explicit DeviceBuffer(std::size_t n) { resize(n); }
  ~DeviceBuffer() { release(); }
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept : m_data(o.m_data), m_size(o.m_size) {
    o.m_data = nullptr;
    o.m_size = 0;
  }

  void resize(std::size_t n) {
    if (n == m_size) return;
    release();
    if (n > 0) FASCIA_CUDA(cudaMalloc(&m_data, n * sizeof(T)));
    m_size = n;
    count_device_buffer_bytes(static_cast<long long>(bytes()));
  }
  template <class U>
  void upload(const std::vector<U>& host) {
    upload(host.data(), host.size());
  }
  template <class U>
  void upload(const U* host, std::size_t n) {
    upload(host, n, cudaStreamLegacy);
    FASCIA_CUDA(cudaStreamSynchronize(cudaStreamLegacy));
  }
  template <class U>
  void upload(const std::vector<U>& host, cudaStream_t stream) {
    upload(host.data(), host.size(), stream);
  }
  template <class U>
  void upload(const U* host, std::size_t n, cudaStream_t stream) {
    resize(n);
    if (n == 0) return;
    if constexpr (std::is_same_v<T, U>) {
      FASCIA_CUDA(cudaMemcpyAsync(m_data, host, n * sizeof(T), cudaMemcpyHostToDevice, stream));
    } else {
      const std::vector<T> converted(host, host + n);
      FASCIA_CUDA(cudaMemcpyAsync(m_data, converted.data(), n * sizeof(T), cudaMemcpyHostToDevice, stream));
    }
  }
  template <class U>
  void download(U* host) const {
    if (m_size == 0) return;
    std::vector<T> tmp(m_size);
    FASCIA_CUDA(cudaMemcpy(tmp.data(), m_data, m_size * sizeof(T), cudaMemcpyDeviceToHost));
    for (std::size_t k = 0; k < m_size; ++k) host[k] = static_cast<U>(tmp[k]);
  }
  void zero() {
    if (m_size == 0) return;
    FASCIA_CUDA(cudaMemset(m_data, 0, m_size * sizeof(T)));
    FASCIA_CUDA(cudaStreamSynchronize(cudaStreamLegacy));
  }

  T* data() { return m_data; }
  const T* data() const { return m_data; }
  std::size_t size() const { return m_size; }
  std::size_t bytes() const { return m_size * sizeof(T); }

 private:
  void release() {
    count_device_buffer_bytes(-static_cast<long long>(bytes()));
    if (m_data) cudaFree(m_data);
    m_data = nullptr;
    m_size = 0;
  }
  T* m_data = nullptr;
  std::size_t m_size = 0;
};

}  // namespace fascia::gpu
