// Connective tissue between two organs (between: [a, b], within: d): its domain, and its
// automatic couplings to both organs.
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"

#include <catch2/catch.hpp>

using namespace fascia::dsl;

namespace {

// Two 10 mm cubes 6 mm apart along x, a tissue within 8 mm of both (more than the gap, so that it
// touches both).
std::string scene_text(const std::string& second_kind) {
  return "fascia: 1\n"
         "materials:\n  soft: {young: 3 kPa, poisson: 0.3}\n  organ: {young: 30 kPa, poisson: 0.3}\n"
         "objects:\n"
         "  a: {material: organ, box: {min: [0, 0, 0], max: [10 mm, 10 mm, 10 mm], cells: [2, 2, 2]}}\n"
         "  b: {material: organ, box: {min: [16 mm, 0, 0], max: [26 mm, 10 mm, 10 mm], cells: [2, 2, 2]}}\n"
         "  ligament:\n    material: soft\n    between: [a, b]\n    within: 8 mm\n"
         "    discretisation: {meshless: {frame_spacing: 1.5 mm, sample_spacing: 0.6 mm}}\n" +
         second_kind +
         "constraints:\n  - fix: a\n    region: {all: true}\n"
         "solver: {integrator: static}\n";
}

}  // namespace

TEST_CASE("a tissue between two organs fills the gap and is shared with both", "[dsl][level_set]") {
  const BuiltScene built = build_scene(parse_scene_text(scene_text(""), "between.yaml"));
  REQUIRE(built.objects.size() == 3);
  const auto& ligament = built.objects[2];
  REQUIRE(ligament.meshless);
  // Within 8 mm of both cubes and outside them: the whole gap between the facing faces, x in
  // [10, 16] mm, and around its rim wherever both distances stay below 8 mm. The volume lies
  // between the slab over the faces, 6 x 10 x 10 mm^3, and that slab widened by 8 mm on every
  // side, 6 x 26 x 26 mm^3.
  const double volume = ligament.meshless->voxel_volume;
  CHECK(volume > 600e-9);
  CHECK(volume < 6 * 26 * 26 * 1e-9);
  // Automatic couplings: frames near each cube are shared with it.
  int shared_a = 0, shared_b = 0;
  for (const CouplingReport& c : built.couplings) {
    CHECK(c.kind == "share");
    CHECK(c.object == "ligament");
    if (c.other == "a") shared_a = c.frames;
    if (c.other == "b") shared_b = c.frames;
  }
  CHECK(shared_a > 0);
  CHECK(shared_b > 0);
}

TEST_CASE("between without within is refused", "[dsl][level_set]") {
  std::string text = scene_text("");
  text.erase(text.find("    within: 8 mm\n"), 17);
  try {
    build_scene(parse_scene_text(text, "between.yaml"));
    FAIL("accepted");
  } catch (const SceneError& e) {
    CHECK_THAT(e.diagnostics().sorted().front().message, Catch::Contains("needs 'within'"));
    CHECK(static_cast<int>(e.exit_code()) == 78);
  }
}
