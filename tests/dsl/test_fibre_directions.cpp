// Where an hgo tissue's fibres run (dsl/build_scene.cpp, place_fibres): the material's direction,
// an object's own, and per-region directions with the material's elsewhere. The direction from
// an organ of a between tissue is tested in test_between_objects.cpp.
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"

#include <catch2/catch.hpp>

#include <cmath>

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

TEST_CASE("two fibre families and the uncoupled formulation reach the materials", "[dsl][hgo]") {
  // Families at +-30 deg about the mean direction in its plane with (0, 1, 0); the object turns
  // the mean direction to x, and the axes follow: cos 30 e1 +- sin 30 e2 with e2 = y.
  const std::string text =
      "fascia: 1\n"
      "materials:\n  lig: {law: hgo, formulation: uncoupled, young: 3 kPa, poisson: 0.49,\n"
      "        fibres: {k1: 20 kPa, k2: 5, dispersion: 0.1, direction: [0, 0, 1], families: 2, angle: 30 deg,\n"
      "                 plane: [0, 1, 0]}}\n"
      "objects:\n"
      "  band:\n    material: lig\n    box: {min: [0, 0, 0], max: [40 mm, 10 mm, 10 mm], cells: [4, 1, 1]}\n"
      "    fibres: {direction: [3, 0, 0]}\n"
      "run: {steps: 1}\n";
  const fascia::Model model = build_scene(parse_scene_text(text, "families.yaml")).model;
  REQUIRE(!model.materials.empty());
  for (const fascia::Material& m : model.materials) {
    CHECK(m.law == fascia::MaterialLaw::hgo);
    CHECK(m.formulation == fascia::HgoFormulation::uncoupled);
    CHECK(m.fibres.families == 2);
    CHECK(m.fibres.angle == Approx(0.5235987755982988).epsilon(1e-15));
    CHECK(m.fibres.direction.x == 1.0);
    for (int k = 0; k < 2; ++k) {
      const fascia::Vec3 a = m.fibres.axes[k];
      CHECK(a.x == Approx(std::sqrt(3.0) / 2).epsilon(1e-15));
      CHECK(a.y == Approx(k == 0 ? 0.5 : -0.5).epsilon(1e-15));
      CHECK(a.z == 0.0);
    }
  }
  // Without the key the formulation is coupled, with one family along the direction.
  const fascia::Model plain = built("");
  CHECK(plain.materials.front().formulation == fascia::HgoFormulation::coupled);
  CHECK(plain.materials.front().fibres.families == 1);
  CHECK(plain.materials.front().fibres.axes[0].z == Approx(0.8).epsilon(1e-15));
}
