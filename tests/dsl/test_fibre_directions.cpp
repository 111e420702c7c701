// Where an hgo tissue's fibres run (dsl/build_scene.cpp, place_fibres): the material's direction,
// an object's own, and per-region directions with the material's elsewhere. The direction from
// an organ of a between tissue is tested in test_between_objects.cpp.
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"

#include <catch2/catch.hpp>

using namespace fascia::dsl;

namespace {

// A 40 x 10 x 10 mm box of hgo material with fibres along (0, 3, 4) unless the object says.
fascia::Model built(const std::string& object_fibres) {
  const std::string text =
      "fascia: 1\n"
      "materials:\n  lig: {law: hgo, young: 3 kPa, fibres: {k1: 20 kPa, k2: 5, direction: [0, 3, 4]}}\n"
      "objects:\n"
      "  band:\n    material: lig\n    box: {min: [0, 0, 0], max: [40 mm, 10 mm, 10 mm], cells: [4, 1, 1]}\n" +
      object_fibres + "run: {steps: 1}\n";
  return build_scene(parse_scene_text(text, "fibres.yaml")).model;
}

fascia::Vec3 direction_at(const fascia::Model& model, int s) {
  return model.materials[static_cast<std::size_t>(model.samples.materials[static_cast<std::size_t>(s)])].fibres.direction;
}

}  // namespace

TEST_CASE("fibres run along the material's direction, an object's own, or per region", "[dsl][hgo]") {
  const fascia::Model plain = built("");
  for (int s = 0; s < plain.sample_count(); ++s) {
    CHECK(direction_at(plain, s).y == Approx(0.6).epsilon(1e-15));  // normalised
    CHECK(direction_at(plain, s).z == Approx(0.8).epsilon(1e-15));
  }
  const fascia::Model own = built("    fibres: {direction: [2, 0, 0]}\n");
  for (int s = 0; s < own.sample_count(); ++s) CHECK(direction_at(own, s).x == 1.0);
  // The first 10 mm along x: along x; the rest: the second region (all; the first match wins),
  // or without it the material's direction.
  const std::string box = "        - {region: {box: [[-1 mm, -1 mm, -1 mm], [10 mm, 11 mm, 11 mm]]}, direction: [1, 0, 0]}\n";
  for (const bool second : {true, false}) {
    const fascia::Model regions =
        built("    fibres:\n      regions:\n" + box +
              (second ? "        - {region: {all: true}, direction: [0, 1, 0]}\n" : ""));
    int first = 0, rest = 0;
    for (int s = 0; s < regions.sample_count(); ++s) {
      const double x = regions.samples.rest_positions[3 * static_cast<std::size_t>(s)];
      const fascia::Vec3 a = direction_at(regions, s);
      if (x <= 10e-3) {
        ++first;
        CHECK(a.x == 1.0);
      } else {
        ++rest;
        CHECK(a.y == Approx(second ? 1.0 : 0.6).epsilon(1e-15));
      }
    }
    CHECK(first > 0);
    CHECK(rest > 0);
  }
}

TEST_CASE("fibre regions select samples by position, not frames by index", "[dsl][hgo]") {
  try {
    built("    fibres: {regions: [{region: {ids: [0]}, direction: [1, 0, 0]}]}\n");
    FAIL("accepted");
  } catch (const SceneError& e) {
    CHECK_THAT(e.diagnostics().sorted().front().message, Catch::Contains("ids select frames"));
    CHECK(static_cast<int>(e.exit_code()) == 78);
  }
}
