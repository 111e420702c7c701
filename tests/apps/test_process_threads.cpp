// The step's automatic thread count (apps/fascia/process_threads.hpp).
#include "process_threads.hpp"

#include "model/model.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::app;

namespace {

Model model_with(int samples, int triangles) {
  Model m;
  m.samples.volumes.assign(static_cast<std::size_t>(samples), 1e-9);
  m.samples.materials.assign(static_cast<std::size_t>(samples), 0);
  m.samples.rest_positions.assign(3 * static_cast<std::size_t>(samples), 0.0);
  if (triangles > 0) {
    Shell shell;
    shell.triangles.assign(3 * static_cast<std::size_t>(triangles), 0);
    m.shells.push_back(shell);
  }
  return m;
}

}  // namespace

TEST_CASE("a step's threads: as requested, or one per kElementsPerThread samples and shell triangles", "[apps]") {
  REQUIRE(model_with(430, 640).sample_count() == 430);
  // Requested counts are kept, even above the cores.
  CHECK(step_threads(model_with(430, 0), 3, 2) == 3);
  // Automatic: at least one, one more per kElementsPerThread elements, at most the cores.
  CHECK(step_threads(model_with(0, 0), 0, 16) == 1);
  CHECK(step_threads(model_with(kElementsPerThread, 0), 0, 16) == 1);
  CHECK(step_threads(model_with(kElementsPerThread + 1, 0), 0, 16) == 2);
  CHECK(step_threads(model_with(430, 640), 0, 16) == 3);  // the pelvis: 1,070 elements
  CHECK(step_threads(model_with(56179, 0), 0, 16) == 16);
  CHECK(step_threads(model_with(56179, 0), 0, 1) == 1);
  CHECK(step_threads(model_with(56179, 0), 0, 0) == 1);  // no count known: one
}
