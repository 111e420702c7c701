// The device's vector operations (kernels/device_vector.hpp): the terms of one scalar, reduced on
// the device and read back together; the frames' rotation as the host's.
#include "device_vector.hpp"
#include "solve/vector_ops.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <stdexcept>
#include <vector>

using namespace fascia;
using namespace fascia::gpu;

TEST_CASE("pending terms are read back together and summed in the order they were enqueued", "[gpu]") {
  cudaStream_t stream = nullptr;
  REQUIRE(cudaStreamCreate(&stream) == cudaSuccess);
  {
    const VectorOps ops(stream);
    // Terms of very different sizes, so that another order of the host's sum would round
    // differently: 1e16, then 1.0 three times (each lost against 1e16 alone), then -1e16.
    const std::vector<double> big{1e16}, one{1.0}, minus_big{-1e16};
    DeviceBuffer<double> a, b, c;
    a.upload(big);
    b.upload(one);
    c.upload(minus_big);
    ops.dot_pending(a.data(), nullptr, 1);
    ops.copy_pending(b.data());
    ops.dot_pending(b.data(), b.data(), 1);
    ops.dot_pending(b.data(), nullptr, 1);
    ops.copy_pending(c.data());
    const double in_order = (((1e16 + 1.0) + 1.0) + 1.0) - 1e16;
    CHECK(ops.read_pending() == in_order);
    CHECK(ops.read_pending() == 0.0);  // emptied by the read
    // dot and finish are a term and its read: with others pending they would mix them in.
    ops.copy_pending(b.data());
    CHECK_THROWS_AS(ops.dot(a.data(), nullptr, 1), std::logic_error);
    CHECK_THROWS_AS(ops.finish(), std::logic_error);
    CHECK(ops.read_pending() == 1.0);
    CHECK(ops.dot(a.data(), a.data(), 1) == 1e32);
    for (int k = 0; k < VectorOps::kPendingTerms; ++k) ops.copy_pending(b.data());
    CHECK_THROWS_AS(ops.copy_pending(b.data()), std::logic_error);
    CHECK(ops.read_pending() == static_cast<double>(VectorOps::kPendingTerms));
  }
  cudaStreamDestroy(stream);
}

TEST_CASE("the device turns the frames' increments as the host does", "[gpu]") {
  cudaStream_t stream = nullptr;
  REQUIRE(cudaStreamCreate(&stream) == cudaSuccess);
  {
    const VectorOps ops(stream);
    const int frames = 300;
    std::vector<double> q(4 * frames), q_ref(4 * frames), x(6 * frames);
    for (int i = 0; i < frames; ++i) {
      store_quat(&q[4 * i], normalized(Quat{std::cos(0.1 * i), std::sin(0.3 * i), 0.2, -0.5}));
      store_quat(&q_ref[4 * i], normalized(Quat{0.4, std::cos(0.7 * i), std::sin(0.2 * i), 0.1}));
    }
    for (int k = 0; k < 6 * frames; ++k) x[k] = std::sin(0.37 * k);
    DeviceBuffer<double> qd, rd, xd, yd(6 * frames);
    qd.upload(q);
    rd.upload(q_ref);
    xd.upload(x);
    const HostVectorOps host(6 * frames, nullptr);
    for (const bool transpose : {false, true}) {
      std::vector<double> expected, got(6 * frames);
      host.rotate_frames(q.data(), q_ref.data(), x, expected, transpose);
      ops.rotate_frames(qd.data(), rd.data(), xd.data(), yd.data(), frames, transpose);
      REQUIRE(cudaMemcpyAsync(got.data(), yd.data(), sizeof(double) * got.size(), cudaMemcpyDeviceToHost, stream) ==
              cudaSuccess);
      REQUIRE(cudaStreamSynchronize(stream) == cudaSuccess);
      // The same arithmetic (core/rotation.hpp); the device may fuse multiply-adds: a few
      // roundings of entries of size 1.
      for (int k = 0; k < 6 * frames; ++k) REQUIRE(std::abs(got[k] - expected[k]) <= 1e-15 * 8);
    }
  }
  cudaStreamDestroy(stream);
}
