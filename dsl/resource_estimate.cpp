#include "dsl/resource_estimate.hpp"

#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace fascia::dsl {

namespace fs = std::filesystem;

namespace {

// Bytes per sample: its row of the neighbour table (frame index 4, weight 8, weight gradient 24,
// rest offset 24 per neighbour) plus about 512 bytes of per-sample state (rest position, volume,
// deformation gradient and stress lanes, the volume shares of the voxelisation).
double sample_bytes(double neighbours) { return 60 * neighbours + 512; }
// Bytes per frame: position, orientation, velocity and about 30 solver vectors of 6 doubles
// (Newton, CG, preconditioner blocks of 6x6), rounded up.
constexpr double kFrameBytes = 2048;
// Bytes per narrow-band voxel of the OpenVDB level set (a float in a partly filled 8^3 leaf).
constexpr double kBandVoxelBytes = 8;
// Size above which a tissue surface is more likely in millimetres than in metres.
constexpr double kLargestBody = 5;  // m

std::string length_text(double metres) {
  char text[64];
  if (metres >= 1e3) std::snprintf(text, sizeof text, "%.3g km", metres / 1e3);
  else if (metres >= 1) std::snprintf(text, sizeof text, "%.3g m", metres);
  else std::snprintf(text, sizeof text, "%.3g mm", metres * 1e3);
  return text;
}

}  // namespace

double machine_memory() {
  double bytes = static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE));
  // A job's cgroup (Slurm, containers) may allow less than the machine has.
  for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream in(path);
    std::string word;
    if (in >> word && !word.empty() && std::isdigit(static_cast<unsigned char>(word[0]))) {
      const double limit = std::strtod(word.c_str(), nullptr);
      if (limit > 0 && limit < bytes) bytes = limit;
    }
  }
  return bytes;
}

double parse_bytes(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !std::isfinite(value) || !(value > 0)) return -1;
  std::string unit(end);
  unit.erase(std::remove(unit.begin(), unit.end(), ' '), unit.end());
  for (char& c : unit) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  const std::string prefixes = "KMGTP";
  if (unit.empty() || unit == "B") return value;
  const std::size_t p = prefixes.find(unit[0]);
  if (p == std::string::npos) return -1;
  const std::string rest = unit.substr(1);
  if (!rest.empty() && rest != "B" && rest != "IB") return -1;
  return value * std::pow(1024.0, static_cast<double>(p + 1));
}

ObjectEstimate estimate_meshless(const SurfaceMesh& surface, const MeshlessOptions& options) {
  ObjectEstimate e;
  Vec3 lo, hi;
  surface_bounds(surface, lo, hi);
  const Vec3 size = hi - lo;
  const double extent = std::max({size.x, size.y, size.z});
  const double volume = std::abs(surface_volume(surface));
  const double area = surface_area(surface);
  const double rf = options.frame_spacing, rs = options.sample_spacing;
  const double h = options.voxel_size > 0 ? options.voxel_size : rs / 2;
  // Points at least r apart: at most one per ball of radius r/2 in the densest packing
  // (density pi / (3 sqrt 2)), so N <= sqrt(2) V / r^3; the boundary layer adds up to A r / 2.
  const auto points = [&](double r) { return std::sqrt(2.0) * (volume + 0.5 * area * r) / (r * r * r); };
  e.frames = points(rf);
  e.samples = points(rs);
  // Narrow band of half width 3 voxels each side of the surface, on the samples' lattice and,
  // where it differs, on the frames' (meshless.hpp, frame lattice).
  const double h_frames = frame_lattice_spacing(rf);
  e.voxels = 7 * area / (h * h) + (h_frames != h ? 7 * area / (h_frames * h_frames) : 0);
  // Dense point grids of cell r / sqrt(3) over the bounding box plus two cells each side.
  const auto grid = [&](double r) {
    double cells = 1;
    for (double s : {size.x, size.y, size.z}) cells *= s * std::sqrt(3.0) / r + 5;
    return 4 * cells;
  };
  // Neighbour frames per sample: the frames within support_scale times the distance holding
  // support_neighbours of them, about support_scale^3 support_neighbours inside the object.
  const double neighbours = std::pow(options.shape.support_scale, 3) * options.shape.support_neighbours;
  // One slice of covered voxels at a time (32 bytes each) per thread.
  const double slice = 32 * (size.x / h + 1) * (size.y / h + 1);
  e.bytes = kBandVoxelBytes * e.voxels + std::max(grid(rf), grid(rs)) + slice +
            e.samples * sample_bytes(neighbours) + e.frames * kFrameBytes;
  if (extent > kLargestBody)
    e.cause = "the surface is " + length_text(extent) +
              " across: missing 'transform: {scale: 1e-3}' for a surface in millimetres?";
  else if (extent / rs > 1000)
    e.cause = "sample_spacing is 1/" + std::to_string(static_cast<long long>(extent / rs)) +
              " of the object's size (" + length_text(extent) + "): check its unit";
  return e;
}

ObjectEstimate estimate_level_set(const SurfaceMesh& surface, double voxel_size, int half_width) {
  ObjectEstimate e;
  Vec3 lo, hi;
  surface_bounds(surface, lo, hi);
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  e.voxels = (2.0 * half_width + 1) * surface_area(surface) / (voxel_size * voxel_size);
  e.bytes = kBandVoxelBytes * e.voxels;
  if (extent > kLargestBody)
    e.cause = "the surface is " + length_text(extent) +
              " across: missing 'transform: {scale: 1e-3}' for a surface in millimetres?";
  return e;
}

ObjectEstimate estimate_label_level_set(const LabelImage& image, const std::vector<int>& labels, double voxel_size,
                                        int half_width) {
  const long long nx = image.size[0], ny = image.size[1], nz = image.size[2];
  const auto selected = [&](long long i, long long j, long long k) {
    if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return false;
    return std::find(labels.begin(), labels.end(), image.at(i, j, k)) != labels.end();
  };
  // Boundary faces normal to each image axis.
  long long faces[3] = {0, 0, 0};
  for (long long k = 0; k < nz; ++k)
    for (long long j = 0; j < ny; ++j)
      for (long long i = 0; i < nx; ++i) {
        const bool in = selected(i, j, k);
        // A face between (i - 1) and i is a boundary face when exactly one side is selected.
        if (in != selected(i - 1, j, k)) ++faces[0];
        if (in != selected(i, j - 1, k)) ++faces[1];
        if (in != selected(i, j, k - 1)) ++faces[2];
        if (in && i == nx - 1) ++faces[0];
        if (in && j == ny - 1) ++faces[1];
        if (in && k == nz - 1) ++faces[2];
      }
  const Mat3& m = image.index_to_world;
  const Vec3 e[3] = {{m.m[0][0], m.m[1][0], m.m[2][0]}, {m.m[0][1], m.m[1][1], m.m[2][1]}, {m.m[0][2], m.m[1][2], m.m[2][2]}};
  const double area = static_cast<double>(faces[0]) * norm(cross(e[1], e[2])) +
                      static_cast<double>(faces[1]) * norm(cross(e[2], e[0])) +
                      static_cast<double>(faces[2]) * norm(cross(e[0], e[1]));
  ObjectEstimate est;
  est.voxels = (2.0 * half_width + 1) * area / (voxel_size * voxel_size);
  est.bytes = kBandVoxelBytes * est.voxels;
  return est;
}

ObjectEstimate estimate_mesh_based(double cells, int nodes, double vertices, int samples_per_cell, double extent) {
  ObjectEstimate e;
  e.frames = vertices;
  e.samples = cells * samples_per_cell;
  e.bytes = e.samples * sample_bytes(nodes) + e.frames * kFrameBytes + cells * nodes * 4.0 + vertices * 24.0;
  if (extent > kLargestBody)
    e.cause = "the mesh is " + length_text(extent) + " across: missing 'transform: {scale: 1e-3}' for millimetres?";
  return e;
}

// The text, the parsed vertices and faces and the importer's own copies: about 8 bytes of memory
// per byte of an ASCII mesh file.
double mesh_file_bytes(double file_bytes) { return 8 * file_bytes; }

double output_bytes(double rows, double bytes_per_row) { return rows * bytes_per_row; }

double free_disk_bytes(const std::string& path) {
  std::error_code ec;
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  struct statvfs info {};
  if (statvfs(dir.c_str(), &info) != 0) return -1;
  return static_cast<double>(info.f_bavail) * static_cast<double>(info.f_frsize);
}

}  // namespace fascia::dsl
