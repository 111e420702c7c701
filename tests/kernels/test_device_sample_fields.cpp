// The sample fields of an output row and their frame averages on the device
// (kernels/device_sample_fields.hpp) against the host's (io/sample_fields.hpp,
// io/vertex_fields.hpp) for the three laws, and an inverted sample whose Cauchy stress and
// principal values are NaN alike.
//
// Bound: both run io/sample_point.hpp on the same doubles; the compilers contract and order the
// floating-point operations differently (fused multiply-adds), a few ulps per operation on values
// formed by a few hundred operations from O(1) terms: 1e-12 of each field's largest value.
#include "device_sample_fields.hpp"
#include "io/vertex_fields.hpp"
#include "kernels_fixtures.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

using namespace fascia;
using namespace fascia::gpu;
using namespace fascia::test;

TEST_CASE("device sample fields equal the host's", "[gpu]") {
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean, MaterialLaw::hgo);
  const Model model = kernels_test_model(CellType::tetrahedron, law, 4, 3, 2);
  State state = random_state(model, 5, 0.004, 0.3);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double& v : state.velocities) v = 0.1 * u(rng);
  std::vector<double> rotations;
  rotation_matrices(state, rotations);
  std::vector<Field> host, device;
  std::vector<double> host_positions, device_positions;
  sample_fields(model, state, rotations, host, &host_positions);
  DeviceSampleFields fields(model);
  fields.compute(state, rotations, device, &device_positions);
  REQUIRE(device.size() == host.size());
  REQUIRE(host.size() == (law == MaterialLaw::hgo ? 12u : 11u));
  auto check = [](const std::string& name, const std::vector<double>& a, const std::vector<double>& b) {
    REQUIRE(a.size() == b.size());
    double largest = 0, diff = 0;
    for (size_t k = 0; k < a.size(); ++k) {
      largest = std::max(largest, std::abs(a[k]));
      diff = std::max(diff, std::abs(a[k] - b[k]));
    }
    CAPTURE(name, largest, diff);
    CHECK(largest > 0);
    CHECK(diff <= 1e-12 * largest);
    return largest > 0 ? diff / largest : 0.0;
  };
  double worst = check("positions", device_positions, host_positions);
  for (size_t f = 0; f < host.size(); ++f) {
    REQUIRE(device[f].name == host[f].name);
    worst = std::max(worst, check(host[f].name, device[f].values, host[f].values));
  }
  // The frames' averages of the measures, of every frame and of every third one.
  std::vector<unsigned char> some(static_cast<size_t>(model.frame_count()), 0);
  for (size_t i = 0; i < some.size(); i += 3) some[i] = 1;
  const std::vector<unsigned char>* masks[2] = {nullptr, &some};
  for (const std::vector<unsigned char>* mask : masks) {
    const std::vector<Field> a = frame_averages(model, host, mask), b = fields.frame_averages(mask);
    REQUIRE(a.size() == b.size());
    for (size_t f = 0; f < a.size(); ++f) {
      REQUIRE(b[f].name == a[f].name);
      worst = std::max(worst, check("frame " + a[f].name, b[f].values, a[f].values));
      if (mask)
        for (size_t i = 0; i < some.size(); ++i)
          if (!some[i])
            for (int c = 0; c < b[f].components; ++c) REQUIRE(b[f].values[i * static_cast<size_t>(b[f].components) + static_cast<size_t>(c)] == 0.0);
    }
  }
  std::printf("[device sample fields %s] %d samples, %zu fields and their frame averages, largest difference %.2e of a "
              "field's largest value\n",
              to_string(law), model.sample_count(), host.size(), worst);
}

TEST_CASE("an inverted sample's stresses are NaN on the device as on the host", "[gpu]") {
  const Model model = kernels_test_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 2, 2, 1);
  State state = rest_state(model);
  for (int i = 0; i < model.frame_count(); ++i) state.positions[3 * static_cast<size_t>(i)] *= -1;  // x -> -x: det F < 0
  std::vector<double> rotations;
  rotation_matrices(state, rotations);
  std::vector<Field> host, device;
  sample_fields(model, state, rotations, host);
  DeviceSampleFields(model).compute(state, rotations, device, nullptr);
  for (size_t f = 0; f < host.size(); ++f)
    for (size_t k = 0; k < host[f].values.size(); ++k) {
      CAPTURE(host[f].name, k);
      REQUIRE(std::isnan(device[f].values[k]) == std::isnan(host[f].values[k]));
    }
  const Field& cauchy = host[4];
  REQUIRE(cauchy.name == "cauchy_stress");
  CHECK(std::isnan(cauchy.values[0]));
}
