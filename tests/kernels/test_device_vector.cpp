// The device's vector operations (kernels/device_vector.hpp): the terms of one scalar, reduced on
// the device and read back together.
#include "device_vector.hpp"

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
