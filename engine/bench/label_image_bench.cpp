#include "bench/label_image_bench.hpp"

#include "discretise/level_set.hpp"
#include "discretise/surface_mesh.hpp"
#include "discretise/voxel_domain.hpp"

#include <nifti2_io.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <stdexcept>

namespace fascia {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Rotation by angle a about axis (Rodrigues).
Mat3 rotation(Vec3 axis, double a) {
  axis = (1 / norm(axis)) * axis;
  return identity3<double>() + std::sin(a) * skew(axis) + (1 - std::cos(a)) * (skew(axis) * skew(axis));
}

}  // namespace

LabelImage label_image_phantom(int n) {
  if (n < 16) throw std::invalid_argument("the label image phantom needs at least 16 voxels a side");
  const double s = n / 256.0;
  LabelImage image;
  image.size = {n, n, n};
  image.labels.assign(static_cast<std::size_t>(n) * static_cast<std::size_t>(n) * static_cast<std::size_t>(n), 0);
#pragma omp parallel for schedule(static)
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        // (i, j, k) in the ellipsoid of centre c and semi-axes a (voxels at n = 256).
        auto in_ellipsoid = [&](Vec3 c, Vec3 a) {
          const double x = (i - s * c.x) / (s * a.x), y = (j - s * c.y) / (s * a.y), z = (k - s * c.z) / (s * a.z);
          return x * x + y * y + z * z <= 1;
        };
        const double ring = std::hypot(i - 60 * s, k - 200 * s) - 25 * s, across = j - 60 * s;
        std::int32_t& v = image.labels[static_cast<std::size_t>(i + n * (j + static_cast<long long>(n) * k))];
        if (in_ellipsoid({110, 128, 120}, {70, 50, 45})) v = 1;
        if (in_ellipsoid({200, 200, 190}, {20, 20, 20})) v = 2;
        if (i >= 180 * s && i < 230 * s && j >= 30 * s && j < 90 * s && k >= 40 * s && k < 70 * s) v = 3;
        if (ring * ring + across * across <= 64 * s * s) v = 4;
      }
  Mat3 edges = zero3<double>();
  edges.m[0][0] = 0.7e-3, edges.m[1][1] = 0.8e-3, edges.m[2][2] = 1.25e-3;
  image.index_to_world = rotation(Vec3{1, -2, 0.5}, 0.4) * edges;
  image.origin = Vec3{-0.0523, 0.0311, 0.1071};
  return image;
}

void write_label_image_phantom(const std::string& path, int n) {
  const LabelImage image = label_image_phantom(n);
  const int64_t dims[8] = {3, n, n, n, 1, 1, 1, 1};
  nifti_image* nim = nifti_make_new_nim(dims, NIFTI_TYPE_INT16, 0);
  if (nim == nullptr) throw std::runtime_error("nifticlib could not make an image header");
  nim->data = std::malloc(image.labels.size() * sizeof(std::int16_t));
  if (nim->data == nullptr) {
    nifti_image_free(nim);
    throw std::bad_alloc();
  }
  auto* data = static_cast<std::int16_t*>(nim->data);
  for (std::size_t v = 0; v < image.labels.size(); ++v) data[v] = static_cast<std::int16_t>(image.labels[v]);
  nim->xyz_units = NIFTI_UNITS_MM;
  double* spacing[3] = {&nim->dx, &nim->dy, &nim->dz};
  nifti_dmat44 m{};
  for (int c = 0; c < 3; ++c) {
    const Vec3 edge{image.index_to_world.m[0][c], image.index_to_world.m[1][c], image.index_to_world.m[2][c]};
    *spacing[c] = nim->pixdim[c + 1] = 1e3 * norm(edge);
    for (int r = 0; r < 3; ++r) m.m[r][c] = 1e3 * image.index_to_world.m[r][c];
  }
  m.m[0][3] = 1e3 * image.origin.x, m.m[1][3] = 1e3 * image.origin.y, m.m[2][3] = 1e3 * image.origin.z;
  m.m[3][3] = 1;
  nim->sform_code = NIFTI_XFORM_SCANNER_ANAT;
  nim->sto_xyz = m;
  nim->sto_ijk = nifti_dmat44_inverse(m);
  nim->nifti_type = NIFTI_FTYPE_NIFTI1_1;
  if (nifti_set_filenames(nim, path.c_str(), 0, 1) != 0) {
    nifti_image_free(nim);
    throw std::runtime_error("cannot name the image file " + path);
  }
  nifti_image_write(nim);
  nifti_image_free(nim);
}

LabelImageBench bench_label_image(const std::string& path) {
  LabelImageBench bench;
  bench.path = path;
  auto t0 = std::chrono::steady_clock::now();
  const LabelImage image = read_label_image(path);
  bench.seconds_read = seconds_since(t0);
  bench.size = image.size;
  double h = 1e300;
  for (int c = 0; c < 3; ++c)
    h = std::min(h, norm(Vec3{image.index_to_world.m[0][c], image.index_to_world.m[1][c], image.index_to_world.m[2][c]}));
  bench.lattice = h;
  std::vector<int> labels;
  for (int label : image.present())
    if (label != 0) labels.push_back(label);
  for (int label : labels) {
    LabelImageBenchRow row;
    row.label = label;
    row.voxels = image.count({label});
    const double expected = static_cast<double>(row.voxels) * image.voxel_volume();
    t0 = std::chrono::steady_clock::now();
    const LevelSet level_set = LevelSet::from_labels(image, {label}, h);
    row.seconds = seconds_since(t0);
    row.domain_error = VoxelDomain(level_set).volume() / expected - 1;
    row.level_set_error = level_set.volume() / expected - 1;
    row.surface_error = surface_volume(level_set.surface()) / expected - 1;
    bench.labels.push_back(row);
  }
  if (!labels.empty()) {
    t0 = std::chrono::steady_clock::now();
    LevelSet::from_labels(image, labels, h);
    bench.seconds_all = seconds_since(t0);
  }
  return bench;
}

void write_label_image_bench(std::ostream& out, const LabelImageBench& b, bool json) {
  if (json) {
    std::string path;  // as a JSON string
    for (char c : b.path) {
      if (c == '"' || c == '\\') path += '\\';
      if (static_cast<unsigned char>(c) >= 0x20) path += c;
    }
    out << std::setprecision(6) << "{\"image\": \"" << path << "\", \"size\": [" << b.size[0] << ", " << b.size[1]
        << ", " << b.size[2] << "], \"lattice\": " << b.lattice << ", \"seconds_read\": " << b.seconds_read
        << ", \"seconds_all_labels\": " << b.seconds_all << ", \"labels\": [";
    for (std::size_t k = 0; k < b.labels.size(); ++k) {
      const LabelImageBenchRow& r = b.labels[k];
      out << (k ? ", " : "") << "{\"label\": " << r.label << ", \"voxels\": " << r.voxels << ", \"seconds\": " << r.seconds
          << ", \"domain_volume_error\": " << r.domain_error << ", \"level_set_volume_error\": " << r.level_set_error
          << ", \"surface_volume_error\": " << r.surface_error << "}";
    }
    out << "]}\n";
  } else {
    out << std::setprecision(4) << b.path << ": " << b.size[0] << " x " << b.size[1] << " x " << b.size[2]
        << " voxels read in " << b.seconds_read << " s; lattice " << 1e3 * b.lattice << " mm\n";
    for (const LabelImageBenchRow& r : b.labels)
      out << "label " << r.label << " (" << r.voxels << " voxels): level set " << r.seconds
          << " s, volume error: domain " << 100 * r.domain_error << " %, OpenVDB " << 100 * r.level_set_error
          << " %, surface " << 100 * r.surface_error << " %\n";
    out << "all labels at once: " << b.seconds_all << " s\n";
  }
  out.flush();
}

}  // namespace fascia
