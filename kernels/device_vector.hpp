// Vector operations on device arrays of doubles: the backend operations that the one Newton and
// the one PCG (engine/solve/newton.hpp, pcg.hpp) are written over (engine/solve/vector_ops.hpp
// gives the concept; DeviceVectorOps implements it), and the device states they step.
//
// Reductions are deterministic: kReduceBlocks blocks of kReduceThreads threads stride over the
// array in a fixed pattern, each block sums its values in a fixed tree, and one block sums the
// partials in a fixed tree (device_vector.cuh). The order depends on neither the device nor the
// launch, so repeated runs give bitwise-identical results. Reductions return to the host through
// pinned reads, the scalars of one evaluation (an energy's terms) in one: with the energies of the
// line search, the only data that cross the bus inside a solve.
//
// All work of one solve is enqueued in order on one stream; device memory of vectors and states
// comes from the stream-ordered allocator (cudaMallocAsync), so the solvers' temporaries cost no
// device synchronisation.
#pragma once

#include "device_buffers.cuh"
#include "solve/linear_result.hpp"

#include <cstdint>
#include <functional>
#include <utility>

namespace fascia::gpu {

// An owning device array of doubles allocated on a stream, movable, not copyable.
class DeviceVector {
 public:
  DeviceVector() = default;
  ~DeviceVector();
  DeviceVector(DeviceVector&& o) noexcept;
  DeviceVector& operator=(DeviceVector&& o) noexcept;
  DeviceVector(const DeviceVector&) = delete;
  DeviceVector& operator=(const DeviceVector&) = delete;

  // Holds n values (contents unspecified); allocations and frees are ordered on `stream`.
  void resize(long long n, cudaStream_t stream);
  double* data() { return m_data; }
  const double* data() const { return m_data; }
  long long size() const { return m_size; }

 private:
  void release();
  double* m_data = nullptr;
  long long m_size = 0;
  cudaStream_t m_stream = nullptr;
};

// Reductions and element-wise operations on device arrays, enqueued on one stream.
class VectorOps {
 public:
  explicit VectorOps(cudaStream_t stream);
  ~VectorOps();
  VectorOps(const VectorOps&) = delete;
  VectorOps& operator=(const VectorOps&) = delete;

  cudaStream_t stream() const { return m_stream; }
  // Reduction scratch for fused kernels: kReduceBlocks values (device_vector.cuh), block b's at b.
  double* partials() const { return m_partials.data(); }

  void copy(const double* x, double* y, long long n) const;
  void fill(double* x, double value, long long n) const;
  void axpy(double a, const double* x, double* y, long long n) const;  // y += a x
  void xpay(const double* x, double a, double* y, long long n) const;  // y = x + a y
  void scale(double a, double* x, long long n) const;                  // x = a x
  // x_k = 0 where fixed[k] (fixed may be null: nothing).
  void project(double* x, const std::uint8_t* fixed, long long n) const;
  // y_i = B_i x_i for 6-vectors and 6x6 row-major blocks B [frames][36]; y_i += B_i x_i where add.
  void block_apply(const double* blocks, const double* x, double* y, int frames, bool add = false) const;
  // sum_k x_k y_k; y null: sum_k x_k.
  double dot(const double* x, const double* y, long long n) const;
  // Sums the kReduceBlocks partials that a fused kernel left in partials() and returns the sum.
  double finish() const;
  // The terms of one scalar read back together: each *_pending enqueues a term into the next of
  // kPendingTerms device slots without a read; read_pending() copies the slots back in one
  // transfer and returns their sum in slot order (the order they were enqueued), emptying them.
  // dot() and finish() are a term and its read, with no other terms pending.
  static constexpr int kPendingTerms = 8;
  void dot_pending(const double* x, const double* y, long long n) const;
  void finish_pending() const;
  void copy_pending(const double* value) const;  // a term already on the device (one double)
  double read_pending() const;

  // The PCG scalars of DeviceVectorOps (the CgScalars concept of engine/solve/vector_ops.hpp), in
  // device memory: each operation is enqueued without a read back; cg_status() reads them.
  void cg_start(const double* r, const double* z, long long n, double tolerance) const;
  // fixed: the projection P of hp and z (null: none).
  void cg_step(const double* p, const double* hp, const double* z, const std::uint8_t* fixed, double* x, double* r,
               long long n) const;
  void cg_direction(const double* r, const double* z, const std::uint8_t* fixed, double* p, long long n) const;
  CgStatus cg_status() const;
  // The operations' one record of work: body() captured as a CUDA graph (body must only enqueue
  // work on this stream), replacing the record before; returns the new record's generation, by
  // which a holder (DeviceVectorOps::Repeated) tells whether the record is still its own. One
  // graph launch then enqueues the dozen or so kernels of a PCG iteration.
  unsigned long record(const std::function<void()>& body) const;
  unsigned long generation() const { return m_generation; }
  // Launches the record `count` times.
  void replay(int count) const;

  struct CgState;  // device_vector.cu

 private:
  cudaStream_t m_stream;
  // The next pending term's slot, after checking that one is free.
  double* next_pending() const;

  mutable DeviceBuffer<double> m_partials, m_pending;  // m_pending: [kPendingTerms]
  mutable DeviceBuffer<unsigned> m_counter;  // a last-block reduction's blocks done (zero between kernels)
  mutable int m_pending_count = 0;
  double* m_host = nullptr;  // pinned [kPendingTerms]
  CgState* m_cg = nullptr;       // device
  CgState* m_cg_host = nullptr;  // pinned
  mutable cudaGraphExec_t m_record = nullptr;  // the last record()
  mutable unsigned long m_generation = 0;       // records made
};

// The vector-operations concept of engine/solve/vector_ops.hpp on DeviceVector: n values, a
// device mask of fixed DOFs (the projection), the operations of `ops`.
class DeviceVectorOps {
 public:
  using Vector = DeviceVector;

  DeviceVectorOps(const VectorOps& ops, long long n, const std::uint8_t* fixed) : m_ops(ops), m_n(n), m_fixed(fixed) {}

  long long size() const { return m_n; }
  void resize(Vector& x) const { x.resize(m_n, m_ops.stream()); }
  void fill(Vector& x, double a) const {
    resize(x);
    m_ops.fill(x.data(), a, m_n);
  }
  void copy(const Vector& x, Vector& y) const {
    resize(y);
    m_ops.copy(x.data(), y.data(), m_n);
  }
  void axpy(double a, const Vector& x, Vector& y) const { m_ops.axpy(a, x.data(), y.data(), m_n); }
  void xpay(const Vector& x, double a, Vector& y) const { m_ops.xpay(x.data(), a, y.data(), m_n); }
  void scale(double a, Vector& x) const { m_ops.scale(a, x.data(), m_n); }
  double dot(const Vector& x, const Vector& y) const { return m_ops.dot(x.data(), y.data(), m_n); }
  double norm(const Vector& x) const;
  void project(Vector& x) const { m_ops.project(x.data(), m_fixed, m_n); }
  const std::uint8_t* fixed() const { return m_fixed; }

  static constexpr bool kScalarsOnHost = false;
  struct CgScalars {};  // held by the VectorOps (one solve at a time per stream)
  void cg_start(CgScalars&, const Vector& r, const Vector& z, double tolerance) const {
    m_ops.cg_start(r.data(), z.data(), m_n, tolerance);
  }
  void cg_step(CgScalars&, const Vector& p, const Vector& hp, const Vector& z, Vector& x, Vector& r) const {
    m_ops.cg_step(p.data(), hp.data(), z.data(), m_fixed, x.data(), r.data(), m_n);
  }
  void cg_direction(CgScalars&, const Vector& r, const Vector& z, Vector& p) const {
    m_ops.cg_direction(r.data(), z.data(), m_fixed, p.data(), m_n);
  }
  CgStatus cg_status(const CgScalars&) const { return m_ops.cg_status(); }
  // Records body at its first run (and again where another record replaced it) and replays it.
  class Repeated {
   public:
    Repeated(const VectorOps& ops, std::function<void()> body) : m_ops(ops), m_body(std::move(body)) {}
    void run(int count) {
      if (count <= 0) return;
      if (m_generation == 0 || m_generation != m_ops.generation()) m_generation = m_ops.record(m_body);
      m_ops.replay(count);
    }

   private:
    const VectorOps& m_ops;
    std::function<void()> m_body;
    unsigned long m_generation = 0;
  };
  template <class Body>
  Repeated repeated(Body& body) const {
    return Repeated(m_ops, std::ref(body));
  }
  const VectorOps& ops() const { return m_ops; }

 private:
  const VectorOps& m_ops;
  long long m_n;
  const std::uint8_t* m_fixed;
};

}  // namespace fascia::gpu
