// Entry point of fascia_gpu_tests: runs the [gpu] tests when a CUDA device is present; otherwise
// says so and exits 77, which CTest reports as "Skipped" (SKIP_RETURN_CODE), never as passed.
#define CATCH_CONFIG_RUNNER
#include "device_elasticity.hpp"

#include <catch2/catch.hpp>

#include <cstdio>

int main(int argc, char* argv[]) {
  Catch::Session session;
  const int rc = session.applyCommandLine(argc, argv);
  if (rc != 0) return rc;
  const fascia::gpu::DeviceInfo info = fascia::gpu::device_info();
  if (info.device_count == 0) {
    const int count = static_cast<int>(Catch::getAllTestCasesSorted(session.config()).size());
    std::printf("no CUDA device: %d [gpu] tests skipped\n", count);
    return 77;
  }
  std::printf("CUDA device: %s, %d SMs, %.1f GiB, peak DRAM bandwidth %.0f GB/s (from device attributes)\n",
              info.name.c_str(), info.multiprocessors, info.memory_gib, info.peak_bandwidth_gbs);
  return session.run();
}
