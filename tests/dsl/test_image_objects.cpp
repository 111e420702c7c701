// Scene objects from label images (image: FILE, label: N or a list): the model, its boundary
// surface, and the exit codes of bad images and absent labels. Images are written here with
// nifticlib.
#include "dsl/build_scene.hpp"
#include "dsl/scene_spec.hpp"

#include <catch2/catch.hpp>
#include <nifti2_io.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>

namespace fs = std::filesystem;
using namespace fascia::dsl;

namespace {

// A 24 x 20 x 16 image of 2 mm voxels at origin (10, -5, 30) mm: label 3 a 10 x 8 x 6 box of
// voxels from (4, 5, 5), label 4 a 6 x 8 x 6 box touching it along +x, 0 elsewhere.
constexpr int kNx = 24, kNy = 20, kNz = 16;
std::string write_image(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "fascia_image_objects";
  fs::create_directories(dir);
  const std::string path = (dir / name).string();
  const int64_t dims[8] = {3, kNx, kNy, kNz, 1, 1, 1, 1};
  nifti_image* nim = nifti_make_new_nim(dims, NIFTI_TYPE_UINT8, 1);
  auto* v = static_cast<unsigned char*>(nim->data);
  for (int k = 0; k < kNz; ++k)
    for (int j = 0; j < kNy; ++j)
      for (int i = 0; i < kNx; ++i) {
        unsigned char& x = v[i + kNx * (j + kNy * k)];
        if (j >= 5 && j < 13 && k >= 5 && k < 11) x = i >= 4 && i < 14 ? 3 : i >= 14 && i < 20 ? 4 : 0;
      }
  nim->dx = nim->dy = nim->dz = nim->pixdim[1] = nim->pixdim[2] = nim->pixdim[3] = 2.0;
  nim->xyz_units = NIFTI_UNITS_MM;
  nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
  nim->sto_xyz = nifti_dmat44{};
  for (int d = 0; d < 3; ++d) nim->sto_xyz.m[d][d] = 2.0;
  nim->sto_xyz.m[0][3] = 10, nim->sto_xyz.m[1][3] = -5, nim->sto_xyz.m[2][3] = 30, nim->sto_xyz.m[3][3] = 1;
  nifti_set_filenames(nim, path.c_str(), 0, 1);
  nifti_image_write(nim);
  nifti_image_free(nim);
  return path;
}

std::string scene_text(const std::string& image, const std::string& label) {
  return "fascia: 1\n"
         "materials:\n  soft: {young: 3 kPa, poisson: 0.3}\n"
         "objects:\n"
         "  organ:\n    material: soft\n    image: " + image + "\n    label: " + label + "\n"
         "    discretisation: {meshless: {frame_spacing: 4 mm, sample_spacing: 1.5 mm}}\n"
         "constraints:\n  - fix: organ\n    region: {all: true}\n"
         "solver: {integrator: static}\n";
}

}  // namespace

TEST_CASE("an image object is the union of its labels' voxels, placed by the image", "[dsl][label_image]") {
  const std::string image = write_image("two_boxes.nii.gz");
  const double voxel = 8e-9;  // (2 mm)^3
  const auto [label, voxels] = GENERATE(std::make_pair(std::string("3"), 480), std::make_pair(std::string("[3, 4]"), 768));
  CAPTURE(label);
  const BuiltScene built = build_scene(parse_scene_text(scene_text(image, label), "image.yaml"));
  REQUIRE(built.objects.size() == 1);
  REQUIRE(built.objects[0].meshless);
  // Consistent integration on the level set's zero surface: the divergence identities hold to
  // the tolerance of the conjugate gradients (shape/consistent_integration.hpp).
  const fascia::MeshlessStatistics& st = *built.objects[0].meshless;
  REQUIRE(st.integration_defect_before > 1e-4);
  REQUIRE(st.integration_defect <= 1e-11);
  // The sample volumes are scaled to the volume the zero surface encloses, which chamfers the
  // boxes' convex edges: measured 0.32-0.34 h^2 per metre of edge with the lattice h = 0.75 mm;
  // bound 0.5 h^2 times the edge length, 4 (20 + 16 + 12) mm for label 3, 4 (32 + 16 + 12) mm
  // for both.
  REQUIRE(built.model.total_volume() == Approx(st.surface_volume).epsilon(1e-9));
  const double h = 0.75e-3, edges = label == "3" ? 0.192 : 0.240;
  REQUIRE(built.model.total_volume() < voxels * voxel);
  REQUIRE(voxels * voxel - built.model.total_volume() < 0.5 * h * h * edges);
  // Before scaling, the voxel coverage of the level set (lattice 0.75 mm, voxels 2 mm) is within
  // 2 % of the zero surface's volume: the coverage ramp adds about 0.07 h^2 per metre of convex
  // edge, the zero surface chamfers them inwards.
  REQUIRE(std::abs(st.volume_error) < 0.02);
  // Placement: every sample lies within the boxes' world extent, x from 10 + 2 (4 - 1/2) mm
  // (frames added for thin parts may lie up to frame_spacing outside).
  const double x_lo = 1e-3 * (10 + 2 * 3.5), x_hi = 1e-3 * (10 + 2 * (label == "3" ? 13.5 : 19.5));
  for (int s = 0; s < built.model.sample_count(); ++s) {
    const double x = built.model.samples.rest_positions[3 * static_cast<std::size_t>(s)];
    REQUIRE(x > x_lo - 1e-9);
    REQUIRE(x < x_hi + 1e-9);
  }
  REQUIRE(!built.objects[0].surface.faces.empty());
}

TEST_CASE("bad images and absent labels stop the scene with the documented exit codes", "[dsl][label_image]") {
  const std::string image = write_image("boxes.nii");
  auto first_error = [](const std::string& text) {
    try {
      build_scene(parse_scene_text(text, "image.yaml"));
    } catch (const SceneError& e) {
      return e.diagnostics().sorted().front();
    }
    FAIL("the scene was accepted");
    return Diagnostic{};
  };
  SECTION("absent label: bad scene, at the label") {
    const Diagnostic d = first_error(scene_text(image, "[3, 7]"));
    CHECK(static_cast<int>(d.code) == 78);
    CHECK_THAT(d.message, Catch::Contains("label 7 is absent") && Catch::Contains("labels present: 0, 3, 4"));
    CHECK(d.where.line == 8);  // the label key
  }
  SECTION("truncated image: bad data, at the image") {
    const std::string cut = image.substr(0, image.size() - 4) + "_cut.nii";
    fs::copy_file(image, cut, fs::copy_options::overwrite_existing);
    fs::resize_file(cut, fs::file_size(cut) - 100);
    const Diagnostic d = first_error(scene_text(cut, "3"));
    CHECK(static_cast<int>(d.code) == 65);
    CHECK_THAT(d.message, Catch::Contains(cut) && Catch::Contains("truncated"));
    CHECK(d.where.line == 7);  // the image key
  }
  SECTION("a lattice too fine for the memory: too large, at sample_spacing, before voxelising") {
    std::string text = scene_text(image, "3");
    text.replace(text.find("sample_spacing: 1.5 mm"), 22, "sample_spacing: 1 um");
    // The box's boundary, 1504 mm^2, in a band of 7 voxels of 0.5 um: about 4e10 voxels.
    const Diagnostic d = first_error(text);
    CHECK(static_cast<int>(d.code) == 71);
    CHECK_THAT(d.message, Catch::Contains("the level set of its voxels"));
    CHECK(d.where.line == 9);  // the sample_spacing key
  }
  SECTION("missing image: missing input") {
    const Diagnostic d = first_error(scene_text(image + ".absent.nii", "3"));
    CHECK(static_cast<int>(d.code) == 66);
  }
  SECTION("image without label") {
    std::string text = scene_text(image, "3");
    text.erase(text.find("    label: 3\n"), 13);
    const Diagnostic d = first_error(text);
    CHECK(static_cast<int>(d.code) == 78);
    CHECK_THAT(d.message, Catch::Contains("needs 'label'"));
  }
}

TEST_CASE("smoothing an image object is reported, and refused beyond frame_spacing", "[dsl][label_image]") {
  const std::string image = write_image("smoothed_boxes.nii.gz");
  std::string text = scene_text(image, "3");
  text.insert(text.find("    discretisation:"), "    smoothing: 1 mm\n");
  const BuiltScene built = build_scene(parse_scene_text(text, "image.yaml"));
  REQUIRE(built.objects.size() == 1);
  // h = 0.75 mm: (1 mm / 0.75 mm)^2 = 1.78 voxels^2, nearest: 3 passes of width 3 (variance 2),
  // a standard deviation of 1.06 mm.
  CHECK_THAT(built.objects[0].discretisation, Catch::Contains("smoothed (standard deviation 1.06"));
  // The sample volumes are those the smoothed zero surface encloses (consistent integration),
  // less than the voxels' 480 x 8e-9 m^3: smoothing moves the box's convex edges inward.
  REQUIRE(built.objects[0].meshless);
  CHECK(built.model.total_volume() == Approx(built.objects[0].meshless->surface_volume).epsilon(1e-9));
  CHECK(built.model.total_volume() < 480 * 8e-9);

  text.replace(text.find("smoothing: 1 mm"), 15, "smoothing: 5 mm");
  try {
    build_scene(parse_scene_text(text, "image.yaml"));
    FAIL("accepted");
  } catch (const SceneError& e) {
    const Diagnostic d = e.diagnostics().sorted().front();
    CHECK(static_cast<int>(d.code) == 78);
    CHECK_THAT(d.message, Catch::Contains("wider than frame_spacing"));
    CHECK(d.where.line == 9);  // the smoothing key
  }
}
