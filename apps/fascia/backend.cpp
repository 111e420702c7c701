#include "backend.hpp"

#if FASCIA_WITH_CUDA
#include "cuda_elasticity.hpp"
#include "cuda_step.hpp"
#include "device_sample_fields.hpp"
#endif

#include <iostream>

namespace fascia::app {

void add_backend_options(CLI::App& command, BackendOptions& options) {
  command
      .add_option("--backend", options.backend,
                  "cpu | cuda (run and study: the whole step on the GPU, every integrator, the scene's linear method "
                  "and preconditioner included; where the cholmod method's dense factor does not fit, the volumetric "
                  "elasticity on the GPU behind the CPU solver; exit 69 without a usable device)")
      ->check(CLI::IsMember({"cpu", "cuda"}));
  command
      .add_option("--precision", options.precision,
                  "cuda: double | single storage of the tangent on the device (single: its products and blocks in "
                  "float; the forces and energies stay double)")
      ->check(CLI::IsMember({"double", "single"}));
}

int resolve_backend(const char* command, const BackendOptions& options, Backend& backend) {
  backend = Backend{};
  if (options.backend == "cpu") {
    if (options.precision != "double") {
      std::cerr << "fascia " << command << ": error: --precision " << options.precision
                << " applies to --backend cuda; the CPU engine computes in double\n";
      return kUsage;
    }
    backend.provenance = {{"backend", "cpu"}};
    backend.description = "cpu";
    return kOk;
  }
#if FASCIA_WITH_CUDA
  const gpu::DeviceInfo info = gpu::device_info();
  if (info.device_count == 0) {
    std::cerr << "fascia " << command << ": error: --backend cuda: no usable CUDA device (no GPU or no driver); "
              << "use --backend cpu\n";
    return kUnavailable;
  }
  backend.context = std::async(std::launch::async, [] { gpu::create_context(); }).share();
  gpu::DeviceOptions device;
  device.precision = options.precision == "single" ? gpu::Precision::single_precision : gpu::Precision::double_precision;
  backend.elasticity = gpu::cuda_elasticity_factory(device);
  backend.step = gpu::cuda_step_factory(device);
  backend.sample_fields = gpu::device_sample_fields_factory();
  backend.memory_refusal = [device](const Model& model, const SimulationSettings& settings) {
    return gpu::device_run_refusal(model, settings, device, model.sample_count() > 0);
  };
  backend.provenance = {{"backend", "cuda"}, {"gpu", info.name}, {"precision", options.precision}};
  backend.description = "cuda (" + info.name + ", " + options.precision + ")";
  return kOk;
#else
  std::cerr << "fascia " << command << ": error: --backend cuda: this fascia was built without CUDA "
            << "(FASCIA_WITH_CUDA=OFF); use --backend cpu\n";
  return kUnavailable;
#endif
}

}  // namespace fascia::app
