// Vector operations on device arrays of doubles, the backend operations the Newton solver and
// the PCG are written over (DESIGN.md, "One step, two backends"): copy, fill, axpy, the
// projection of fixed DOFs, and dot products reduced on the device.
//
// Reductions are deterministic: kReduceBlocks blocks of kReduceThreads threads stride over the
// array in a fixed pattern, each block sums its values in a fixed tree, and one block sums the
// partials in a fixed tree. The order depends on neither the device nor the launch, so repeated
// runs give bitwise-identical results. Each reduction returns to the host through a pinned
// 8-byte (or 16-byte) read: the only data that crosses the bus in the solver loops.
#pragma once

#include "device_buffers.cuh"

#include <cstdint>
#include <utility>

namespace fascia::gpu {

// The operations on one stream, with the reduction scratch and a pinned host slot for results.
// Sizes n are element counts; pointers are device arrays.
class VectorOps {
 public:
  explicit VectorOps(cudaStream_t stream);
  ~VectorOps();
  VectorOps(const VectorOps&) = delete;
  VectorOps& operator=(const VectorOps&) = delete;

  cudaStream_t stream() const { return m_stream; }
  // Reduction scratch for fused kernels: 2 kReduceBlocks values (device_vector.cuh), value w of
  // block b at w kReduceBlocks + b.
  double* partials() { return m_partials.data(); }

  void copy(const double* x, double* y, long long n);
  void fill(double* x, double value, long long n);
  void axpy(double a, const double* x, double* y, long long n);   // y += a x
  void xpay(const double* x, double a, double* y, long long n);   // y = x + a y
  // y = s x on the free DOFs, 0 on the fixed ones (fixed may be null).
  void scale_project(double s, const double* x, const std::uint8_t* fixed, double* y, long long n);
  // sum_k x_k y_k (over the free DOFs where fixed is non-null); y null: sum_k x_k.
  double dot(const double* x, const double* y, long long n, const std::uint8_t* fixed = nullptr);
  // The fused update of the (preconditioned) conjugate gradients over the free DOFs, for 6-DOF
  // frames: x += alpha p, r -= alpha Hp, z = P^{-1} r with P^{-1} the [frames][36] inverse
  // diagonal blocks (z = r where minv is null), fixed entries of r and z zero. Returns (r.r, r.z).
  std::pair<double, double> cg_update(int frames, double alpha, const double* p, const double* hp, const double* minv,
                                      const std::uint8_t* fixed, double* x, double* r, double* z);
  // Sums the partials of `width` values (1 or 2) that a fused kernel left in partials() and
  // returns them to the host (valid until the next call).
  const double* finish(int width);

 private:
  cudaStream_t m_stream;
  DeviceBuffer<double> m_partials, m_result;
  double* m_host = nullptr;  // pinned
};

}  // namespace fascia::gpu
