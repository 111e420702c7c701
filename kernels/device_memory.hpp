// Device memory of a run with --backend cuda: what the device objects' buffers hold, counted as
// they allocate and free (DeviceBuffer, DeviceVector), and its estimate from the model's figures
// before anything is allocated, which `fascia run` compares with the device's free memory
// (refused with exit 71 beyond it, as dsl/resource_estimate.hpp refuses host memory).
//
// The estimate is a bound, not a budget: its constants are rounded up from the bytes the shipped
// scenes' device objects hold (tests/kernels/test_device_memory.cpp checks every shipped scene and
// the pelvis at 16k samples between the counted bytes and twice them plus 64 MiB).
#pragma once

#include "model/model.hpp"

#include <string>

namespace fascia::gpu {

// The bytes the device buffers hold now.
long long device_buffer_bytes();
// Called by the buffers: + bytes allocated, - bytes freed.
void count_device_buffer_bytes(long long delta);

// What a run puts on the device: the step (the elasticity, the step's potential and vectors, and
// with `factorised` the dense factor with the material columns it is assembled from) and, with
// `sample_rows`, the output rows' sample fields (DeviceSampleFields).
struct DeviceRun {
  bool factorised = false;
  bool sample_rows = false;
  bool start_tangent = false;  // stiffness-proportional damping: a second elasticity, K(q_n)
  bool single = false;         // single precision: the elasticity's double copy for the forces
  bool variational = false;    // the variational integrator's terms (device_variational.hpp)
};

// Estimated device bytes of `run` for `model` (host-side figures only), in double storage: single
// stores less.
double estimate_device_bytes(const Model& model, const DeviceRun& run);

// Empty when the estimate fits in `free` bytes (of the device's `total`), else why not: the
// estimate, the free memory and the parts of the estimate.
std::string device_memory_refusal(const Model& model, const DeviceRun& run, double free, double total);

}  // namespace fascia::gpu
