// `--backend cpu|cuda` and `--precision double|single` of `fascia run` and `fascia study`. With
// cuda, `fascia run` runs the whole step on the device (kernels/cuda_step.hpp) where that covers
// the scene; elsewhere, and in `fascia study`, the CUDA kernels (kernels/cuda_elasticity.hpp)
// evaluate the volumetric energy, forces and tangent products behind the CPU engine's Newton
// solver (docs/gpu.md); the output rows' sample fields are computed on the device too.
#pragma once

#include "commands.hpp"
#include "integrate/step_backend.hpp"
#include "io/sample_fields.hpp"
#include "mechanics/volumetric_elasticity.hpp"

#include <nlohmann/json.hpp>

#include <future>
#include <string>

namespace fascia::app {

struct BackendOptions {
  std::string backend = "cpu";       // cpu | cuda
  std::string precision = "double";  // cuda: storage precision on the device
};

// Adds --backend and --precision to a subcommand.
void add_backend_options(CLI::App& command, BackendOptions& options);

struct Backend {
  ElasticityFactory elasticity;  // empty for cpu
  StepBackendFactory step;       // cuda: the whole step on the device where it covers the scene
  SampleFieldsFactory sample_fields;  // cuda: the output rows' sample fields on the device
  // cuda: why a run of the model with the settings would not fit in the device's free memory
  // ("" when it fits; kernels/device_memory.hpp).
  std::function<std::string(const Model&, const SimulationSettings&)> memory_refusal;
  // cuda: the device's context, created on another thread while the scene is discretised
  // (gpu::create_context); the last copy's destruction waits for it.
  std::shared_future<void> context;
  nlohmann::json provenance;     // {"backend", and for cuda "gpu", "precision"}
  std::string description;       // for logs: "cpu" or "cuda (NVIDIA H200, double)"
};

// Resolves the options. Without a usable CUDA device, or in a build without CUDA, prints one
// line "fascia <command>: error: ..." on stderr and returns kUnavailable; `--precision single`
// with the CPU backend likewise returns kUsage; kOk otherwise.
int resolve_backend(const char* command, const BackendOptions& options, Backend& backend);

}  // namespace fascia::app
