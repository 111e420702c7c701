// The device memory estimate (kernels/device_memory.hpp) against the bytes the device objects of a
// run hold: every shipped scene and the pelvis at 16k samples.
#include "cuda_elasticity.hpp"
#include "cuda_step.hpp"
#include "device_cholesky.hpp"
#include "device_memory.hpp"
#include "device_problem.hpp"
#include "device_sample_fields.hpp"
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"
#include "integrate/simulation.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

using namespace fascia;
using namespace fascia::gpu;

TEST_CASE("the device memory estimate bounds what a run's device objects hold", "[gpu]") {
  const std::string dir = std::filesystem::is_directory("scenes") ? "scenes" : std::string(FASCIA_SOURCE_DIR) + "/scenes";
  std::vector<std::pair<std::string, std::vector<std::string>>> cases;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".yaml") cases.push_back({entry.path().string(), {}});
  std::sort(cases.begin(), cases.end());
  REQUIRE(!cases.empty());
  cases.push_back({dir + "/pelvis.yaml",
                   {"objects.fasciae.discretisation.meshless.frame_spacing=3mm",
                    "objects.fasciae.discretisation.meshless.sample_spacing=1mm"}});
  for (const auto& [path, overrides] : cases) {
    const dsl::BuiltScene built = dsl::build_scene(dsl::parse_scene(path, overrides));
    const Model& model = built.model;
    // Single precision holds a second copy of the elasticity, in double, for the forces.
    for (const Precision precision : {Precision::double_precision, Precision::single_precision}) {
      DeviceOptions options;
      options.precision = precision;
      SimulationSettings device = built.settings;
      device.elasticity = cuda_elasticity_factory(options);
      device.step_backend = cuda_step_factory(options);
      const long long start = device_buffer_bytes();
      long long step = 0, elasticity = 0, fields = 0;
      bool whole = false;
      {
        Simulation simulation(model, built.loads, device, built.motions);
        step = device_buffer_bytes() - start;
        whole = simulation.on_step_backend();
      }
      if (model.sample_count() > 0) {
        DeviceElasticity alone(model, options);
        elasticity = device_buffer_bytes() - start;
      }
      {
        const auto rows = device_sample_fields_factory()(model);
        fields = device_buffer_bytes() - start;
      }
      CHECK(device_buffer_bytes() == start);  // every buffer counted back when freed
      DeviceRun run;
      run.factorised = whole && DeviceProblem::factorises(device.newton.linear) &&
                       DeviceCholesky::refusal(model.dof_count(), model.pair_count()).empty();
      run.sample_rows = true;
      run.single = precision == Precision::single_precision;
      const double counted = static_cast<double>(step + fields);
      const double estimate = estimate_device_bytes(model, run);
      double terms = 0, triangles = 0;
      for (size_t s = 0; s + 1 < model.neighbours.offsets.size(); ++s) {
        const double k = model.neighbours.offsets[s + 1] - model.neighbours.offsets[s];
        terms += k * k;
      }
      for (const Shell& shell : model.shells) triangles += static_cast<double>(shell.triangles.size()) / 3;
      std::printf("[device memory] %s%s, %s: pairs %d samples %d frames %d triangles %.0f terms %.0f dofs %d%s | "
                  "step %lld (elasticity %lld) fields %lld | estimate %.0f (%.2f of counted)\n",
                  path.c_str(), overrides.empty() ? "" : " (16k)", to_string(precision), model.pair_count(),
                  model.sample_count(), model.frame_count(), triangles, terms, model.dof_count(),
                  run.factorised ? " factorised" : "", step, elasticity, fields, estimate, estimate / counted);
      // An upper bound that does not refuse what fits by more than twice (plus the small scenes'
      // fixed buffers).
      CHECK(counted <= estimate);
      CHECK(estimate <= 2 * counted + 64.0 * (1 << 20));
    }
  }
}
