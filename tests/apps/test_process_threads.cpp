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
  CHECK(step_threads(model_with(430, 0), 3, 2, true) == 3);
  // Automatic: at least one, one more per kElementsPerThread elements, at most the cores.
  CHECK(step_threads(model_with(0, 0), 0, 16, true) == 1);
  CHECK(step_threads(model_with(kElementsPerThread, 0), 0, 16, true) == 1);
  CHECK(step_threads(model_with(kElementsPerThread + 1, 0), 0, 16, true) == 2);
  CHECK(step_threads(model_with(430, 640), 0, 16, true) == 3);  // the pelvis: 1,070 elements
  CHECK(step_threads(model_with(56179, 0), 0, 16, true) == 16);
  CHECK(step_threads(model_with(16305, 640), 0, 16, true) == 16);  // the pelvis at 16k: 1,059 per core
  CHECK(step_threads(model_with(56179, 0), 0, 1, true) == 1);
  CHECK(step_threads(model_with(56179, 0), 0, 0, true) == 1);  // no count known: one
}

TEST_CASE("a step that would take every core of several, with few elements per core and a row per step, leaves one to the rows",
          "[apps]") {
  // Below kElementsPerCoreOwned elements per core: one core fewer.
  CHECK(step_threads(model_with(430, 640), 0, 2, true) == 1);  // the pelvis on two cores
  CHECK(step_threads(model_with(2 * kElementsPerCoreOwned - 1, 0), 0, 2, true) == 1);
  CHECK(step_threads(model_with(4 * kElementsPerCoreOwned - 1, 0), 0, 4, true) == 3);
  // From kElementsPerCoreOwned per core: every core.
  CHECK(step_threads(model_with(2 * kElementsPerCoreOwned, 0), 0, 2, true) == 2);
  CHECK(step_threads(model_with(16305, 640), 0, 2, true) == 2);
  // Fewer wanted than the cores: the rows have the rest already.
  CHECK(step_threads(model_with(430, 640), 0, 4, true) == 3);
  // One core: the step's, the rows in turn.
  CHECK(step_threads(model_with(430, 640), 0, 1, true) == 1);
  // Requested counts are kept.
  CHECK(step_threads(model_with(430, 640), 2, 2, true) == 2);
  // Rows rarer than steps (static runs, output.every > 1): every core.
  CHECK(step_threads(model_with(430, 640), 0, 2, false) == 2);
  CHECK(step_threads(model_with(2 * kElementsPerCoreOwned - 1, 0), 0, 2, false) == 2);
}
