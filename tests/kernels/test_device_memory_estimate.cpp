// The device memory estimate's refusal (kernels/device_memory.hpp), on the host: the GPU test
// (test_device_memory.cpp) bounds the estimate by what the device objects hold.
#include "device_memory.hpp"

#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::gpu;

TEST_CASE("the device memory refusal names the estimate, the free memory and its parts", "[kernels]") {
  const Model model = test::small_box_model(CellType::hexahedron);
  DeviceRun step;
  DeviceRun factorised;
  factorised.factorised = true;
  factorised.sample_rows = true;
  const double bytes = estimate_device_bytes(model, step);
  // The factor (18 n^2 bytes and more) and the rows only add.
  CHECK(estimate_device_bytes(model, factorised) >= bytes + 18.0 * model.dof_count() * model.dof_count());
  CHECK(device_memory_refusal(model, factorised, 1e12, 2e12).empty());
  const std::string why = device_memory_refusal(model, factorised, 1e4, 80.0 * 1024 * 1024 * 1024);
  CHECK_THAT(why, Catch::Contains("of device memory, 9.77 KiB are free (of 80 GiB)"));
  CHECK_THAT(why, Catch::Contains("the dense factor of " + std::to_string(model.dof_count()) + " DOFs"));
  CHECK_THAT(why, Catch::Contains("the rows' sample fields"));
  CHECK_THAT(why, Catch::Contains("coarsen the discretisation"));
  CHECK(!device_memory_refusal(model, step, bytes * 0.99, 1e12).empty());
  CHECK(device_memory_refusal(model, step, bytes, 1e12).empty());
  // Single precision keeps a second copy of the elasticity, in double, for the forces.
  DeviceRun single = step;
  single.single = true;
  CHECK(estimate_device_bytes(model, single) > bytes);
  CHECK_THAT(device_memory_refusal(model, single, 1e4, 1e12), Catch::Contains("again in double for the forces"));
}
