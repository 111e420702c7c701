// Connective tissue between two organs (between: [a, b], within: d): its domain, and its
// automatic couplings to both organs.
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"

#include <catch2/catch.hpp>

#include <algorithm>

using namespace fascia::dsl;

namespace {

// Tagged [long]: each builds the tissue on a 0.3 mm lattice over several centimetres, a minute
// or more of a Release build; tools/test-all leaves them out of the run under the sanitizers
// (docs/fuzzing.md), where the same code runs in the lighter [level_set] cases.
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

TEST_CASE("a tissue between two organs fills the gap and is shared with both", "[dsl][level_set][long]") {
  const BuiltScene built = build_scene(parse_scene_text(scene_text(""), "between.yaml"));
  REQUIRE(built.objects.size() == 3);
  const auto& ligament = built.objects[2];
  REQUIRE(ligament.meshless);
  // Within 8 mm of both cubes and outside them: the whole gap between the facing faces, x in
  // [10, 16] mm, and around its rim wherever both distances stay below 8 mm. The volume lies
  // between the slab over the faces, 6 x 10 x 10 mm^3, and that slab widened by 8 mm on every
  // side, 6 x 26 x 26 mm^3.
  // Consistent integration on the level set's zero surface (shape/consistent_integration.hpp).
  CHECK(ligament.meshless->integration_defect <= 1e-11);
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

TEST_CASE("fibres from an organ follow the gradient of its distance", "[dsl][level_set][hgo][long]") {
  std::string text = scene_text("    fibres: {from: a}\n");
  const std::string soft = "soft: {young: 3 kPa, poisson: 0.3}";
  text.replace(text.find(soft), soft.size(), "soft: {law: hgo, young: 3 kPa, poisson: 0.3, fibres: {k1: 20 kPa, k2: 5}}");
  const BuiltScene built = build_scene(parse_scene_text(text, "between.yaml"));
  const fascia::Model& model = built.model;
  int fibred = 0, in_gap = 0;
  for (int s = 0; s < model.sample_count(); ++s) {
    const fascia::Material& m = model.materials[static_cast<std::size_t>(model.samples.materials[static_cast<std::size_t>(s)])];
    if (m.law != fascia::MaterialLaw::hgo) continue;
    ++fibred;
    const double* p = &model.samples.rest_positions[3 * static_cast<std::size_t>(s)];
    const fascia::Vec3 a = m.fibres.direction;
    CHECK(fascia::norm(a) == Approx(1.0).epsilon(1e-14));
    // Away from cube a: the distance to it grows along a. In the gap over the facing faces
    // (x in (10, 16) mm, y and z inside the faces by more than a lattice voxel, 0.3 mm, plus the
    // central difference's voxel) the nearest point of a lies on its face x = 10 mm, so the
    // gradient is e_x up to the lattice's interpolation of a planar distance, which is exact.
    if (p[1] > 1e-3 && p[1] < 9e-3 && p[2] > 1e-3 && p[2] < 9e-3 && p[0] > 10.5e-3 && p[0] < 15.5e-3) {
      ++in_gap;
      CHECK(a.x > 0.999);
    }
  }
  CHECK(fibred > 100);
  CHECK(in_gap > 20);
}

TEST_CASE("a region cuts the tissue between two organs, still shared with both", "[dsl][level_set][long]") {
  std::string text = scene_text("");
  const BuiltScene whole = build_scene(parse_scene_text(text, "between.yaml"));
  text.insert(text.find("    within: 8 mm\n"), "    region: {half_space: {point: [0, 5 mm, 0], normal: [0, 1, 0]}}\n");
  const BuiltScene built = build_scene(parse_scene_text(text, "between.yaml"));
  const auto& ligament = built.objects[2];
  REQUIRE(ligament.meshless);
  CHECK_THAT(ligament.discretisation, Catch::Contains("in its region"));
  // The plane y = 5 mm halves the cubes' facing faces, and the tissue is symmetric about it
  // (cubes from y = 0 to 10 mm): half the volume, up to the lattice's rounding (h = 0.3 mm on a
  // cut of about 26 x 26 mm against a volume of several cm^3: well under 5 %).
  CHECK(ligament.meshless->voxel_volume ==
        Approx(0.5 * whole.objects[2].meshless->voxel_volume).epsilon(0.05));
  // The samples in the gap (x in (10, 16) mm, away from the cubes' quadrature points) are the
  // ligament's: none lies above the plane, where the whole tissue has some.
  const auto highest_in_gap = [](const fascia::Model& model) {
    double y = -1;
    for (int s = 0; s < model.sample_count(); ++s) {
      const double* p = &model.samples.rest_positions[3 * static_cast<std::size_t>(s)];
      if (p[0] > 10.5e-3 && p[0] < 15.5e-3) y = std::max(y, p[1]);
    }
    return y;
  };
  CHECK(highest_in_gap(whole.model) > 6e-3);
  CHECK(highest_in_gap(built.model) <= 5e-3);
  int shared_a = 0, shared_b = 0;
  for (const CouplingReport& c : built.couplings) {
    if (c.other == "a") shared_a = c.frames;
    if (c.other == "b") shared_b = c.frames;
  }
  CHECK(shared_a > 0);
  CHECK(shared_b > 0);
}
