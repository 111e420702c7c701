#include "dsl/build_scene.hpp"
#include "dsl/diagnostics.hpp"
#include "dsl/scene_spec.hpp"
#include "dsl/source_tree.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

using namespace fascia::dsl;
namespace fs = std::filesystem;

namespace {

const char* kSlab = R"(fascia: 1
materials:
  soft: {young: 3 kPa, poisson: 0.45, density: 1 g/cm^3}
objects:
  slab:
    material: soft
    box: {min: [0, 0, 0], max: [0.1, 0.02, 0.02], cells: [4, 1, 1]}
constraints:
  - {fix: slab, region: {box: [[-1, -1, -1], [0, 1, 1]]}}
loads:
  - gravity: 0 0 -9.81 m/s^2
  - motion: {object: slab, region: {half_space: {point: [0.1, 0, 0], normal: [-1, 0, 0]}}, velocity: [20 mm/s, 0, 0], end: 50 ms}
solver: {integrator: backward_euler, dt: 10 ms}
run: {duration: 0.1 s}
)";

}  // namespace

TEST_CASE("a good scene parses into SI values with defaults", "[dsl]") {
  const SceneSpec s = parse_scene_text(kSlab, "slab.yaml");
  REQUIRE(s.materials.size() == 1);
  CHECK(s.materials[0].young.value == Approx(3000));
  CHECK(s.materials[0].density.value == Approx(1000));
  CHECK(s.materials[0].law.value == "stvk");  // default
  CHECK(s.materials[0].young.where.str() == "slab.yaml:3:17");
  REQUIRE(s.objects.size() == 1);
  CHECK(s.objects[0].box->cells.value == std::array<int, 3>{4, 1, 1});
  CHECK(s.solver.dt.value == Approx(0.01));
  CHECK(s.solver.linear_method.value == "pcg");
  CHECK(s.run.step_count == 10);
  CHECK(s.output.file == "slab.h5");
  REQUIRE(s.loads.size() == 2);
  CHECK(s.loads[0].vector.value[2] == Approx(-9.81));
  CHECK(s.loads[1].vector.value[0] == Approx(0.02));
  CHECK(*s.loads[1].end == Approx(0.05));
  // The resolved scene carries defaults and SI units.
  CHECK_THAT(s.resolved_yaml, Catch::Contains("young: 3000 Pa"));
  CHECK_THAT(s.resolved_yaml, Catch::Contains("max_iterations: 50"));
}

TEST_CASE("the resolved scene parses again to the same values", "[dsl]") {
  const SceneSpec s = parse_scene_text(kSlab, "slab.yaml");
  const SceneSpec again = parse_scene_text(s.resolved_yaml, "resolved.yaml");
  CHECK(again.materials[0].young.value == s.materials[0].young.value);
  CHECK(again.solver.dt.value == s.solver.dt.value);
  CHECK(again.run.step_count == s.run.step_count);
  CHECK(again.resolved_yaml == s.resolved_yaml);
}

TEST_CASE("overrides (--set) replace values, creating sections, before validation", "[dsl]") {
  const SceneSpec s = parse_scene_text(kSlab, "slab.yaml",
                                       {"materials.soft.young=50kPa", "solver.dt=5ms", "solver.newton.tolerance=1e-9",
                                        "loads.0.gravity=[0, 0, -1]", "run.duration=20 ms"});
  CHECK(s.materials[0].young.value == Approx(50e3));
  CHECK(s.materials[0].young.where.str() == "--set:1:22");
  CHECK(s.solver.dt.value == Approx(0.005));
  CHECK(s.solver.newton_tolerance == Approx(1e-9));
  CHECK(s.loads[0].vector.value[2] == Approx(-1));
  CHECK(s.run.step_count == 4);
}

TEST_CASE("every problem is reported at once, sorted by position", "[dsl]") {
  const char* text = R"(materials:
  soft: {young: -1 kPa, poisson: 0.7, densty: 3}
solver: {dt: 0 s, integrator: euler}
objects:
  slab: {material: hard, box: {min: [0, 0, 0], max: [1, 1, 1]}}
)";
  try {
    parse_scene_text(text, "many.yaml");
    FAIL("no error");
  } catch (const SceneError& e) {
    const auto d = e.diagnostics().sorted();
    INFO(e.diagnostics().str());
    REQUIRE(d.size() >= 6);
    for (std::size_t i = 1; i < d.size(); ++i) CHECK_FALSE(d[i].where < d[i - 1].where);
    CHECK(d[0].where.str() == "many.yaml:2:17");
    CHECK_THAT(e.diagnostics().str(), Catch::Contains("unknown key 'densty'"));
    CHECK_THAT(e.diagnostics().str(), Catch::Contains("did you mean 'density'"));
    CHECK_THAT(e.diagnostics().str(), Catch::Contains("many.yaml:3:14: dt must be > 0 s"));
    CHECK_THAT(e.diagnostics().str(), Catch::Contains("unknown material 'hard'"));
    CHECK(e.exit_code() == ExitCode::bad_scene);
  }
}

TEST_CASE("include merges a base scene under the including one", "[dsl]") {
  const fs::path dir = fs::temp_directory_path() / "fascia_test_include";
  fs::create_directories(dir / "base");
  std::ofstream(dir / "base/common.yaml") << "materials:\n  soft: {young: 3 kPa, poisson: 0.3}\nsolver: {dt: 1 ms}\n";
  std::ofstream(dir / "scene.yaml") << "extends: base/common.yaml\nmaterials:\n  soft: {poisson: 0.4}\n"
                                       "objects:\n  slab: {material: soft, box: {min: [0,0,0], max: [1,1,1]}}\n"
                                       "run: {steps: 2}\n";
  const SceneSpec s = parse_scene((dir / "scene.yaml").string());
  CHECK(s.materials[0].young.value == Approx(3000));
  CHECK(s.materials[0].poisson.value == Approx(0.4));
  CHECK(s.solver.dt.value == Approx(1e-3));
  CHECK_THAT(s.materials[0].young.where.file, Catch::Contains("common.yaml"));
  CHECK(s.run.step_count == 2);
  fs::remove_all(dir);
}

TEST_CASE("a scene builds into a model with constraints, loads and motions", "[dsl]") {
  const SceneSpec s = parse_scene_text(kSlab, "slab.yaml");
  const BuiltScene b = build_scene(s);
  CHECK(b.model.frame_count() == 5 * 2 * 2);
  CHECK(b.stats.fixed_frames == 4);
  CHECK(b.stats.mass == Approx(1000 * 0.1 * 0.02 * 0.02));
  CHECK(b.loads.gravity.z == Approx(-9.81));
  REQUIRE(b.motions.size() == 1);
  CHECK(b.motions[0].frames.size() == 4);
  CHECK(b.motions[0].end == Approx(0.05));
  CHECK(b.settings.dt == Approx(0.01));
  CHECK(b.steps == 10);
  REQUIRE(b.objects.size() == 1);
  CHECK(b.objects[0].surface.nodes_per_face == 4);
  // A 4x1x1 grid of hexahedra has 4*2 + 4*2 + 2 boundary quads.
  CHECK(b.objects[0].surface.faces.size() == 4 * 18u);
}

TEST_CASE("a surface force integrates the traction over the selected faces", "[dsl]") {
  const char* text = R"(materials: {soft: {young: 3 kPa}}
objects:
  slab: {material: soft, box: {min: [0, 0, 0], max: [2, 1, 1], cells: [2, 2, 2]}}
constraints: [{fix: slab, region: {box: [[-1, -1, -1], [0, 2, 2]]}}]
loads:
  - surface_force: {object: slab, region: {box: [[1.9, -1, -1], [3, 2, 2]]}, traction: [0, 0, -10 Pa]}
solver: {integrator: static}
)";
  const BuiltScene b = build_scene(parse_scene_text(text, "traction.yaml"));
  double fz = 0;
  for (const auto& f : b.loads.point_forces) fz += f.force.z;
  CHECK(fz == Approx(-10.0 * 1 * 1));  // traction x area of the end face x = 2
}

TEST_CASE("source positions: duplicate keys and yaml errors", "[dsl]") {
  Diagnostics d;
  parse_yaml("a: 1\nb:\n  c: 2\n  c: 3\n", "dup.yaml", d);
  REQUIRE(d.size() == 1);
  CHECK(d.sorted()[0].str() == "dup.yaml:4:3: duplicate key 'c' (first defined at dup.yaml:3:3)");
}

TEST_CASE("did-you-mean suggests close names only", "[dsl]") {
  CHECK(closest_match("yuong", {"young", "poisson", "density"}) == "young");
  CHECK(closest_match("materails", {"materials", "objects"}) == "materials");
  CHECK(closest_match("zzzz", {"young", "poisson"}).empty());
}

TEST_CASE("a surface force on a meshless tissue becomes material-point forces of the same total", "[dsl]") {
  const std::string surface = std::string(FASCIA_SOURCE_DIR) + "/scenes/meshes/slab_mm.obj";
  const std::string text = "materials: {soft: {young: 3 kPa}}\n"
                           "objects:\n  slab: {material: soft, surface: " + surface +
                           ", transform: {scale: 1e-3},\n"
                           "         discretisation: {meshless: {frame_spacing: 5 mm, sample_spacing: 2.5 mm}}}\n"
                           "constraints: [{fix: slab, region: {half_space: {point: [4 mm, 0, 0], normal: [1, 0, 0]}}}]\n"
                           "loads:\n  - surface_force: {object: slab, region: {box: [[59 mm, -1, -1], [61 mm, 1, 1]]},"
                           " traction: [0, 0, -10 Pa]}\n"
                           "solver: {integrator: static}\n";
  const BuiltScene b = build_scene(parse_scene_text(text, "meshless.yaml"));
  REQUIRE(b.objects.size() == 1);
  CHECK(b.objects[0].skinned);
  CHECK(b.objects[0].surface.faces.size() == 36u);  // 12 triangles
  REQUIRE(b.loads.material_point_forces.size() == 2);  // the two triangles of the end face x = 60 mm
  double fz = 0, wsum = 0;
  for (const auto& f : b.loads.material_point_forces) {
    fz += f.force.z;
    for (double w : f.weights) wsum += w;
  }
  CHECK(fz == Approx(-10.0 * 0.02 * 0.01));  // traction x end-face area
  CHECK(wsum == Approx(2.0));                 // partition of unity at each point
  CHECK(b.stats.fixed_frames > 0);
}

TEST_CASE("meshless settings reach the discretisation; check's statistics come with the object", "[dsl]") {
  const std::string surface = std::string(FASCIA_SOURCE_DIR) + "/scenes/meshes/slab_mm.obj";  // 60 x 20 x 10 mm
  const auto build = [&](const std::string& meshless) {
    const std::string text = "materials: {soft: {young: 3 kPa}}\n"
                             "objects:\n  slab: {material: soft, surface: " + surface +
                             ", transform: {scale: 1e-3},\n"
                             "         discretisation: {meshless: {" + meshless + "}}}\n"
                             "run: {steps: 1}\n";
    return build_scene(parse_scene_text(text, "meshless.yaml"));
  };
  const BuiltScene a = build("frame_spacing: 5 mm, sample_spacing: 2.5 mm");
  REQUIRE(a.objects.size() == 1);
  REQUIRE(a.objects[0].meshless);
  const fascia::MeshlessStatistics& sa = *a.objects[0].meshless;
  CHECK(sa.frames == a.model.frame_count());
  CHECK(sa.neighbours_max > 8);  // every frame whose support (default k = 8) covers the sample
  CHECK(sa.describe().find("frames " + std::to_string(sa.frames)) != std::string::npos);
  const BuiltScene b = build("frame_spacing: 5 mm, sample_spacing: 2.5 mm, neighbours: 16, seed: 7");
  CHECK(b.objects[0].meshless->neighbours_mean > sa.neighbours_mean);  // larger supports
  CHECK(b.model.frame_rest_positions != a.model.frame_rest_positions);
  // A 60 x 60 x 3 mm sheet with frames 10 mm apart: one layer, neighbour frames nearly coplanar.
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / "fascia_test_meshless";
  fs::create_directories(dir);
  std::ofstream(dir / "sheet.obj") << "v 0 0 0\nv 60 0 0\nv 60 60 0\nv 0 60 0\nv 0 0 3\nv 60 0 3\nv 60 60 3\nv 0 60 3\n"
                                      "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
                                      "f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
  const auto sheet = [&](const std::string& meshless) {
    const std::string text = "materials: {soft: {young: 3 kPa}}\n"
                             "objects:\n  sheet: {material: soft, surface: " + (dir / "sheet.obj").string() +
                             ", transform: {scale: 1e-3},\n"
                             "         discretisation: {meshless: {" + meshless + "}}}\n"
                             "run: {steps: 1}\n";
    return build_scene(parse_scene_text(text, "sheet.yaml"));
  };
  const BuiltScene repaired = sheet("frame_spacing: 10 mm, sample_spacing: 2 mm");
  CHECK(repaired.objects[0].meshless->added_frames > 0);
  CHECK_THROWS_AS(sheet("frame_spacing: 10 mm, sample_spacing: 2 mm, thin_parts: stop"), SceneError);
}

TEST_CASE("solver.adaptive takes backward_euler and static, and names the variational integrator as refused",
          "[dsl][adaptive]") {
  const std::string adaptive = "solver.adaptive={tolerance: 1 mm, min_dt: 1 ms}";
  for (const char* integrator : {"backward_euler", "static"}) {
    const SceneSpec s = parse_scene_text(kSlab, "slab.yaml", {std::string("solver.integrator=") + integrator, adaptive});
    CHECK(s.solver.adaptive);
    CHECK(s.solver.adaptive_tolerance == Approx(1e-3).epsilon(1e-15));
  }
  try {
    parse_scene_text(kSlab, "slab.yaml", {"solver.integrator=variational", adaptive});
    FAIL("no error");
  } catch (const SceneError& e) {
    CHECK_THAT(e.diagnostics().str(), Catch::Contains("'integrator: backward_euler' or 'static'"));
    CHECK(e.exit_code() == ExitCode::bad_scene);
  }
}
