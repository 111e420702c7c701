// Label images read through nifticlib and teem, written here by the same libraries: geometry
// (spacing, origin, oblique orientation), the level set's volume per label, and bad files.
#include "discretise/label_image.hpp"
#include "discretise/level_set.hpp"
#include "discretise/voxel_domain.hpp"

#include <catch2/catch.hpp>
#include <nifti2_io.h>
#include <teem/nrrd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

using namespace fascia;

namespace {

std::string temp_path(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "fascia_label_image";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

// A 40 x 36 x 30 image: label 1 a ball of radius 9 voxels around voxel (14, 16, 15), label 2 a
// box of 8 x 10 x 12 voxels, label 0 elsewhere. Returns labels in file order (i fastest).
constexpr int kNx = 40, kNy = 36, kNz = 30;
std::vector<std::int16_t> phantom() {
  std::vector<std::int16_t> v(static_cast<std::size_t>(kNx * kNy * kNz), 0);
  for (int k = 0; k < kNz; ++k)
    for (int j = 0; j < kNy; ++j)
      for (int i = 0; i < kNx; ++i) {
        std::int16_t& x = v[static_cast<std::size_t>(i + kNx * (j + kNy * k))];
        const double di = i - 14, dj = j - 16, dk = k - 15;
        if (di * di + dj * dj + dk * dk <= 81) x = 1;
        if (i >= 28 && i < 36 && j >= 4 && j < 14 && k >= 10 && k < 22) x = 2;
      }
  return v;
}

// Rotation by angle a about a unit axis (Rodrigues).
Mat3 rotation(Vec3 axis, double a) {
  axis = (1 / norm(axis)) * axis;
  return identity3<double>() + std::sin(a) * skew(axis) + (1 - std::cos(a)) * (skew(axis) * skew(axis));
}

// Writes `labels` as NIfTI with voxel edges given by the columns of `edges` (mm) and origin (mm),
// through the sform (sform_code 1) or the qform (qform_code 1, edges must be a rotation times a
// diagonal).
void write_nifti(const std::string& path, const std::vector<std::int16_t>& labels, const Mat3& edges_mm,
                 const Vec3& origin_mm, bool use_sform, int version = 1) {
  const int64_t dims[8] = {3, kNx, kNy, kNz, 1, 1, 1, 1};
  nifti_image* nim = nifti_make_new_nim(dims, NIFTI_TYPE_INT16, 0);
  REQUIRE(nim != nullptr);
  nim->data = std::malloc(labels.size() * sizeof(std::int16_t));
  std::memcpy(nim->data, labels.data(), labels.size() * sizeof(std::int16_t));
  nim->xyz_units = NIFTI_UNITS_MM;
  double spacing[3];
  for (int c = 0; c < 3; ++c) spacing[c] = norm(Vec3{edges_mm.m[0][c], edges_mm.m[1][c], edges_mm.m[2][c]});
  nim->dx = nim->pixdim[1] = spacing[0];
  nim->dy = nim->pixdim[2] = spacing[1];
  nim->dz = nim->pixdim[3] = spacing[2];
  nifti_dmat44 m{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m.m[r][c] = edges_mm.m[r][c];
  }
  m.m[0][3] = origin_mm.x, m.m[1][3] = origin_mm.y, m.m[2][3] = origin_mm.z, m.m[3][3] = 1;
  if (use_sform) {
    nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
    nim->sto_xyz = m;
    nim->sto_ijk = nifti_dmat44_inverse(m);
    nim->qform_code = 0;
  } else {
    nim->qform_code = NIFTI_XFORM_SCANNER_ANAT;
    double dx, dy, dz;
    nifti_dmat44_to_quatern(m, &nim->quatern_b, &nim->quatern_c, &nim->quatern_d, &nim->qoffset_x, &nim->qoffset_y,
                            &nim->qoffset_z, &dx, &dy, &dz, &nim->qfac);
    nim->sform_code = 0;
  }
  nim->nifti_type = version == 2 ? NIFTI_FTYPE_NIFTI2_1 : NIFTI_FTYPE_NIFTI1_1;
  REQUIRE(nifti_set_filenames(nim, path.c_str(), 0, 1) == 0);
  nifti_image_write(nim);
  nifti_image_free(nim);
}

// The same as NRRD in a left-posterior-superior space (Slicer's convention), gzip encoded.
void write_nrrd_lps(const std::string& path, std::vector<std::int16_t> labels, const Mat3& edges_ras_mm,
                    const Vec3& origin_ras_mm) {
  Nrrd* nrrd = nrrdNew();
  REQUIRE(nrrdWrap_va(nrrd, labels.data(), nrrdTypeShort, 3, static_cast<size_t>(kNx), static_cast<size_t>(kNy),
                      static_cast<size_t>(kNz)) == 0);
  nrrdSpaceSet(nrrd, nrrdSpaceLeftPosteriorSuperior);
  for (int c = 0; c < 3; ++c) {
    nrrd->axis[c].spaceDirection[0] = -edges_ras_mm.m[0][c];
    nrrd->axis[c].spaceDirection[1] = -edges_ras_mm.m[1][c];
    nrrd->axis[c].spaceDirection[2] = edges_ras_mm.m[2][c];
    nrrd->axis[c].kind = nrrdKindSpace;
  }
  nrrd->spaceOrigin[0] = -origin_ras_mm.x;
  nrrd->spaceOrigin[1] = -origin_ras_mm.y;
  nrrd->spaceOrigin[2] = origin_ras_mm.z;
  NrrdIoState* nio = nrrdIoStateNew();
  nio->encoding = nrrdEncodingGzip;
  REQUIRE(nrrdSave(path.c_str(), nrrd, nio) == 0);
  nrrdIoStateNix(nio);
  nrrdNix(nrrd);  // the data belongs to `labels`
}

Mat3 oblique_edges_mm() {
  // Anisotropic voxels 0.8 x 1.1 x 1.5 mm, rotated by 0.5 rad about (1, 2, 3).
  Mat3 d = zero3<double>();
  d.m[0][0] = 0.8, d.m[1][1] = 1.1, d.m[2][2] = 1.5;
  return rotation(Vec3{1, 2, 3}, 0.5) * d;
}

void require_same(const Mat3& a, const Mat3& b, double tol) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) REQUIRE(a.m[r][c] == Approx(b.m[r][c]).margin(tol));
}

long long count_of(const std::vector<std::int16_t>& v, int label) {
  return static_cast<long long>(std::count(v.begin(), v.end(), static_cast<std::int16_t>(label)));
}

}  // namespace

TEST_CASE("label images keep labels, spacing, origin and oblique orientation", "[label_image]") {
  const std::vector<std::int16_t> labels = phantom();
  const Mat3 edges = oblique_edges_mm();
  const Vec3 origin{-20.5, 13.25, 101.0};
  const std::string format = GENERATE(std::string("nifti1 sform"), std::string("nifti1 qform gz"),
                                      std::string("nifti2 sform"), std::string("nrrd lps gz"));
  std::string path;
  if (format == "nifti1 sform") write_nifti(path = temp_path("oblique_sform.nii"), labels, edges, origin, true);
  if (format == "nifti1 qform gz") write_nifti(path = temp_path("oblique_qform.nii.gz"), labels, edges, origin, false);
  if (format == "nifti2 sform") write_nifti(path = temp_path("oblique_n2.nii"), labels, edges, origin, true, 2);
  if (format == "nrrd lps gz") write_nrrd_lps(path = temp_path("oblique.seg.nrrd"), labels, edges, origin);
  CAPTURE(format);
  const LabelImage image = read_label_image(path);
  REQUIRE(image.size == std::array<long long, 3>{kNx, kNy, kNz});
  REQUIRE(image.labels.size() == labels.size());
  for (std::size_t v = 0; v < labels.size(); ++v) REQUIRE(image.labels[v] == labels[v]);
  // NIfTI-1 stores the sform rows, the quaternion and the voxel sizes as floats: relative 6e-8
  // of edges up to 1.5 mm and an origin of 101 mm is below 1e-5 mm = 1e-8 m. NIfTI-2 and NRRD
  // store doubles.
  require_same(image.index_to_world, 1e-3 * edges, 1e-8);
  REQUIRE(image.origin.x == Approx(1e-3 * origin.x).margin(1e-8));
  REQUIRE(image.origin.y == Approx(1e-3 * origin.y).margin(1e-8));
  REQUIRE(image.origin.z == Approx(1e-3 * origin.z).margin(1e-8));
  REQUIRE(image.voxel_volume() == Approx(0.8 * 1.1 * 1.5 * 1e-9).epsilon(1e-6));
  REQUIRE(image.present() == std::vector<int>{0, 1, 2});
}

TEST_CASE("a label's level set holds its voxels' volume where the image places them", "[label_image]") {
  const std::vector<std::int16_t> labels = phantom();
  const Mat3 edges = oblique_edges_mm();
  const Vec3 origin{-20.5, 13.25, 101.0};
  const std::string path = temp_path("volume.nii.gz");
  write_nifti(path, labels, edges, origin, true);
  const LabelImage image = read_label_image(path);
  // The level set holds exact distances to the voxels' faces. The boundary surface, polygonised
  // from the lattice, cuts the staircase's convex edges and corners, an error that falls as h^2:
  // for a ball of radius 9 voxels, -2.7 % at h = 0.8 mm (the smallest voxel edge), -1.0 % at
  // 0.4 mm, -0.25 % at 0.2 mm. The volumes of the level set itself are tested at h = one voxel
  // edge in test_level_set.cpp.
  const double h = 0.2e-3;
  for (int label : {1, 2}) {
    CAPTURE(label);
    const LevelSet level_set = LevelSet::from_labels(image, {label}, h);
    const double expected = static_cast<double>(count_of(labels, label)) * image.voxel_volume();
    // Goal of the label input: within 1 % of voxel count x voxel volume (measured: ball -0.5 to
    // -0.1 %, box within 0.15 %, for OpenVDB's measure, the voxel coverage and the surface).
    REQUIRE(level_set.volume() == Approx(expected).epsilon(0.01));
    const VoxelDomain domain(level_set);
    REQUIRE(domain.volume() == Approx(expected).epsilon(0.01));
    // The boundary surface is closed, outward (positive volume) and encloses the same volume.
    const SurfaceMesh surface = level_set.surface();
    REQUIRE(check_surface(surface).closed());
    REQUIRE(surface_volume(surface) == Approx(expected).epsilon(0.01));
    // Position and orientation: the label's centre maps through the oblique affine.
    const Vec3 centre_index = label == 1 ? Vec3{14, 16, 15} : Vec3{31.5, 8.5, 15.5};
    const Vec3 centre = image.index_to_world * centre_index + image.origin;
    REQUIRE(domain.inside(centre));
    Vec3 lo, hi;
    surface_bounds(surface, lo, hi);
    const Vec3 mid = 0.5 * (lo + hi);
    // The box's world bounding box is centred on the box's centre; the ball's too. Half a voxel
    // diagonal (1 mm) bounds the asymmetry of the voxelised ball about its centre voxel.
    REQUIRE(norm(mid - centre) < 1e-3);
    // One voxel edge outside the ball along the image's j axis is outside.
    if (label == 1) REQUIRE(!domain.inside(image.index_to_world * Vec3{14, 26, 15} + image.origin));
  }
  // A list of labels is their union.
  const LevelSet both = LevelSet::from_labels(image, {1, 2}, h);
  REQUIRE(both.volume() ==
          Approx(static_cast<double>(count_of(labels, 1) + count_of(labels, 2)) * image.voxel_volume()).epsilon(0.01));
  REQUIRE_THROWS_AS(LevelSet::from_labels(image, {7}, h), std::invalid_argument);
}

namespace {

LabelImageError::Kind error_kind(const std::string& path, std::string& message) {
  try {
    read_label_image(path);
  } catch (const LabelImageError& e) {
    message = e.what();
    return e.kind();
  }
  FAIL("no error for " << path);
  return LabelImageError::Kind::bad_data;
}

}  // namespace

TEST_CASE("bad label images get a message naming the file", "[label_image]") {
  std::string message;
  const std::string missing = temp_path("absent.nii");
  std::filesystem::remove(missing);
  REQUIRE(error_kind(missing, message) == LabelImageError::Kind::missing_input);
  REQUIRE(message.find(missing) != std::string::npos);

  const std::vector<std::int16_t> labels = phantom();
  Mat3 edges = identity3<double>();
  SECTION("unknown extension") {
    const std::string path = temp_path("labels.png");
    std::ofstream(path) << "not an image";
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find("unknown label image format") != std::string::npos);
  }
  SECTION("not a NIfTI file") {
    const std::string path = temp_path("garbage.nii");
    std::ofstream(path) << std::string(400, 'x');
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find(path) == 0);
  }
  SECTION("truncated NIfTI") {
    const std::string path = temp_path("truncated.nii");
    write_nifti(path, labels, edges, Vec3{0, 0, 0}, true);
    std::filesystem::resize_file(path, std::filesystem::file_size(path) / 2);
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find("truncated") != std::string::npos);
  }
  SECTION("NIfTI header asking for more data than its file holds") {
    // 1000^3 int16 voxels (2 GB, within kMaxLabelImageVoxels) in a file of a few kilobytes:
    // refused from the file's size, before nifticlib allocates the 2 GB.
    const std::string path = temp_path("oversized.nii");
    write_nifti(path, labels, edges, Vec3{0, 0, 0}, true);
    {
      std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
      const std::int16_t big = 1000;
      for (int d = 1; d <= 3; ++d) {
        f.seekp(40 + 2 * d);
        f.write(reinterpret_cast<const char*>(&big), sizeof big);
      }
    }
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find(path) == 0);
    REQUIRE(message.find("asks for 2000000352 bytes of voxel data") != std::string::npos);
  }
  SECTION("huge NIfTI header") {
    const std::string path = temp_path("huge.nii");
    write_nifti(path, labels, edges, Vec3{0, 0, 0}, true);
    {  // NIfTI-1: short dim[8] at byte 40; ask for 30000^3 voxels
      std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
      const std::int16_t big = 30000;
      for (int d = 1; d <= 3; ++d) {
        f.seekp(40 + 2 * d);
        f.write(reinterpret_cast<const char*>(&big), 2);
      }
    }
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find("30000 x 30000 x 30000") != std::string::npos);
  }
  SECTION("huge NRRD header") {
    const std::string path = temp_path("huge.nrrd");
    std::ofstream(path) << "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 100000 100000 100000\nencoding: raw\n\n";
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find("more than") != std::string::npos);
  }
  SECTION("truncated NRRD") {
    const std::string path = temp_path("truncated.nrrd");
    std::ofstream(path) << "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 10 10 10\nencoding: raw\n\n"
                        << std::string(300, '\1');
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find("truncated") != std::string::npos);
  }
  SECTION("non-label data") {
    const std::string path = temp_path("intensity.nrrd");
    std::vector<float> values(1000);
    for (std::size_t v = 0; v < values.size(); ++v) values[v] = 0.25f * static_cast<float>(v);
    Nrrd* nrrd = nrrdNew();
    REQUIRE(nrrdWrap_va(nrrd, values.data(), nrrdTypeFloat, 3, size_t{10}, size_t{10}, size_t{10}) == 0);
    REQUIRE(nrrdSave(path.c_str(), nrrd, nullptr) == 0);
    nrrdNix(nrrd);
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find("voxel 1 ") != std::string::npos);
    REQUIRE(message.find("not a label") != std::string::npos);
  }
  SECTION("four dimensions") {
    const std::string path = temp_path("series.nrrd");
    std::vector<unsigned char> values(2 * 3 * 4 * 5, 1);
    Nrrd* nrrd = nrrdNew();
    REQUIRE(nrrdWrap_va(nrrd, values.data(), nrrdTypeUChar, 4, size_t{2}, size_t{3}, size_t{4}, size_t{5}) == 0);
    REQUIRE(nrrdSave(path.c_str(), nrrd, nullptr) == 0);
    nrrdNix(nrrd);
    REQUIRE(error_kind(path, message) == LabelImageError::Kind::bad_data);
    REQUIRE(message.find("4 axes") != std::string::npos);
  }
}
