// libfascia_openvdb.so: LevelSet and VoxelDomain on OpenVDB grids (discretise/voxel_module.hpp),
// loaded on a process's first voxelisation.
#include "discretise/voxel_module.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/LevelSetMeasure.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/VolumeToMesh.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace fascia {
namespace {

// openvdb::initialize(), once per process.
void initialise_openvdb() {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
}

// The world lattice's transform. OpenVDB's linear transforms refuse scales whose cube is near
// zero (below about 2e-5 m).
openvdb::math::Transform::Ptr lattice_transform(double voxel_size) {
  try {
    return openvdb::math::Transform::createLinearTransform(voxel_size);
  } catch (const openvdb::ArithmeticError&) {
    std::ostringstream message;
    message << "a voxel size of " << voxel_size
            << " m is below the smallest that OpenVDB's transforms accept (about 2e-5 m; the voxel size is half the "
               "sample spacing): this object is too small for a meshless discretisation at this spacing";
    throw std::invalid_argument(message.str());
  }
}

// Trilinear interpolation of the grid at world point x (voxel centres at h * index).
template <class Accessor>
double interpolate(const Accessor& acc, const Vec3& x, double inverse_h) {
  const openvdb::Vec3d index(x.x * inverse_h, x.y * inverse_h, x.z * inverse_h);
  return openvdb::tools::BoxSampler::sample(acc, index);
}

// Passes and width of the box filters that smooth() applies: n passes of 2w + 1 voxels, variance
// n w (w + 1) / 3 voxels^2 (each pass: a mean over 2w + 1 voxels along x, then y, then z).
struct BoxPasses {
  int passes = 0, width = 1;
};

BoxPasses box_passes(double standard_deviation, double voxel_size) {
  const double variance = standard_deviation * standard_deviation / (voxel_size * voxel_size);  // voxels^2
  BoxPasses best;
  if (!(variance > 0)) return best;
  // The (passes, width) pair with the variance nearest the one asked, at most 8 passes; of equal
  // ones, the fewest voxel reads (passes x width).
  double best_error = 1e300;
  const int widest = 1 + static_cast<int>(std::ceil(std::sqrt(3 * variance)));
  for (int passes = 1; passes <= 8; ++passes)
    for (int width = 1; width <= widest; ++width) {
      const double error = std::abs(passes * width * (width + 1) / 3.0 - variance);
      if (error < best_error - 1e-12 ||
          (error < best_error + 1e-12 && passes * width < best.passes * best.width)) {
        best_error = error;
        best = BoxPasses{passes, width};
      }
    }
  return best;
}

// A narrow-band signed distance field: a grid of linear transform of voxel size h, background =
// the band (m).
struct VdbLevelSet final : LevelSet::Impl {
  openvdb::FloatGrid::Ptr grid;
  double h = 0;

  double voxel_size() const override { return h; }
  double band() const override { return grid->background(); }
  double volume() const override { return openvdb::tools::levelSetVolume(*grid, true); }

  Vec3 gradient(const Vec3& x) const override {
    const auto acc = grid->getConstAccessor();
    const auto phi = [&](double dx, double dy, double dz) {
      const openvdb::Vec3d index((x.x + dx) / h, (x.y + dy) / h, (x.z + dz) / h);
      return static_cast<double>(openvdb::tools::BoxSampler::sample(acc, index));
    };
    return Vec3{(phi(h, 0, 0) - phi(-h, 0, 0)) / (2 * h), (phi(0, h, 0) - phi(0, -h, 0)) / (2 * h),
                (phi(0, 0, h) - phi(0, 0, -h)) / (2 * h)};
  }

  double smooth(double standard_deviation) override {
    if (standard_deviation < 0) throw std::invalid_argument("smoothing: the standard deviation must not be negative");
    const BoxPasses b = box_passes(standard_deviation, h);
    if (b.passes == 0) return 0;
    if (band() < (b.width + 2) * h * (1 - 1e-6))
      throw std::invalid_argument("smoothing: the level set's band is narrower than the filter needs");
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    openvdb::tools::LevelSetFilter<openvdb::FloatGrid> filter(*grid);
    for (int pass = 0; pass < b.passes; ++pass) filter.mean(b.width);
    return h * std::sqrt(b.passes * b.width * (b.width + 1) / 3.0);
  }

  SurfaceMesh surface() const override {
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> triangles;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*grid, points, triangles, quads, 0.0, 0.0);
    SurfaceMesh mesh;
    mesh.vertices.reserve(3 * points.size());
    for (const openvdb::Vec3s& p : points) mesh.vertices.insert(mesh.vertices.end(), {p.x(), p.y(), p.z()});
    // OpenVDB orders polygons clockwise seen from outside; reversed here to the outward
    // (counter-clockwise) orientation used by surface_volume().
    for (const openvdb::Vec3I& t : triangles)
      mesh.triangles.insert(mesh.triangles.end(), {static_cast<int>(t[2]), static_cast<int>(t[1]), static_cast<int>(t[0])});
    auto length2 = [&](unsigned a, unsigned b) { return (points[a] - points[b]).lengthSqr(); };
    for (const openvdb::Vec4I& q : quads) {
      const int a = static_cast<int>(q[0]), b = static_cast<int>(q[1]), c = static_cast<int>(q[2]), d = static_cast<int>(q[3]);
      if (length2(q[0], q[2]) <= length2(q[1], q[3]))
        mesh.triangles.insert(mesh.triangles.end(), {c, b, a, d, c, a});
      else
        mesh.triangles.insert(mesh.triangles.end(), {d, b, a, d, c, b});
    }
    return mesh;
  }
};

std::unique_ptr<VdbLevelSet> level_set_from_labels(const LabelImage& image, const std::vector<int>& labels,
                                                   double voxel_size, int half_width) {
  if (!(voxel_size > 0)) throw std::invalid_argument("voxel size must be positive");
  if (labels.empty()) throw std::invalid_argument("no label selected");
  initialise_openvdb();
  const long long nx = image.size[0], ny = image.size[1], nz = image.size[2];
  const int lo = *std::min_element(labels.begin(), labels.end()), hi = *std::max_element(labels.begin(), labels.end());
  std::vector<unsigned char> wanted(static_cast<std::size_t>(static_cast<long long>(hi) - lo + 1), 0);
  for (int l : labels) wanted[static_cast<std::size_t>(static_cast<long long>(l) - lo)] = 1;
  auto selected = [&](long long i, long long j, long long k) {
    if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return false;
    const std::int32_t v = image.labels[static_cast<std::size_t>(i + nx * (j + ny * k))];
    return v >= lo && v <= hi && wanted[static_cast<std::size_t>(static_cast<long long>(v) - lo)] != 0;
  };
  // Image index point (voxel centres at integers, faces at half-integers) to the index space of
  // the world lattice (world position / h), which meshToVolume expects.
  const double inverse_h = 1 / voxel_size;
  auto world = [&](double i, double j, double k) {
    const Vec3 x = inverse_h * (image.index_to_world * Vec3{i, j, k} + image.origin);
    return openvdb::Vec3s(static_cast<float>(x.x), static_cast<float>(x.y), static_cast<float>(x.z));
  };
  // The faces between a selected voxel and an unselected one (or the image's edge), one slice of
  // k per task: the exact boundary of the union of the selected voxels.
  std::vector<std::vector<openvdb::Vec3s>> slice_points(static_cast<std::size_t>(nz));
  long long count = 0;
#pragma omp parallel for schedule(dynamic, 4) reduction(+ : count)
  for (long long k = 0; k < nz; ++k) {
    std::vector<openvdb::Vec3s>& out = slice_points[static_cast<std::size_t>(k)];
    for (long long j = 0; j < ny; ++j)
      for (long long i = 0; i < nx; ++i) {
        if (!selected(i, j, k)) continue;
        ++count;
        const double x0 = i - 0.5, x1 = i + 0.5, y0 = j - 0.5, y1 = j + 0.5, z0 = k - 0.5, z1 = k + 0.5;
        if (!selected(i - 1, j, k)) out.insert(out.end(), {world(x0, y0, z0), world(x0, y0, z1), world(x0, y1, z1), world(x0, y1, z0)});
        if (!selected(i + 1, j, k)) out.insert(out.end(), {world(x1, y0, z0), world(x1, y1, z0), world(x1, y1, z1), world(x1, y0, z1)});
        if (!selected(i, j - 1, k)) out.insert(out.end(), {world(x0, y0, z0), world(x1, y0, z0), world(x1, y0, z1), world(x0, y0, z1)});
        if (!selected(i, j + 1, k)) out.insert(out.end(), {world(x0, y1, z0), world(x0, y1, z1), world(x1, y1, z1), world(x1, y1, z0)});
        if (!selected(i, j, k - 1)) out.insert(out.end(), {world(x0, y0, z0), world(x0, y1, z0), world(x1, y1, z0), world(x1, y0, z0)});
        if (!selected(i, j, k + 1)) out.insert(out.end(), {world(x0, y0, z1), world(x1, y0, z1), world(x1, y1, z1), world(x0, y1, z1)});
      }
  }
  if (count == 0) throw std::invalid_argument("no voxel holds the selected labels");
  std::size_t total = 0;
  for (const auto& s : slice_points) total += s.size();
  std::vector<openvdb::Vec3s> points;
  points.reserve(total);
  for (auto& s : slice_points) {
    points.insert(points.end(), s.begin(), s.end());
    std::vector<openvdb::Vec3s>().swap(s);
  }
  std::vector<openvdb::Vec4I> quads(points.size() / 4);
  for (std::size_t q = 0; q < quads.size(); ++q) {
    const auto v = static_cast<openvdb::Index32>(4 * q);
    quads[q] = openvdb::Vec4I(v, v + 1, v + 2, v + 3);
  }
  // Exact distances to the faces on the world lattice; the sign comes from a flood fill, so face
  // orientation and the edges where two voxels touch are harmless. Renormalisation is off: it
  // replaces each value by the smaller of itself and an Eikonal-corrected one, meant to smooth
  // the bumps of overlapping triangles (faces of voxels never overlap). Along the staircase's
  // edges and corners, where the exact distance has kinks, that minimum moves the zero level
  // outward by a fraction of a lattice voxel and inflates every label: +5 % for a ball of radius 9
  // voxels at h = one voxel edge, +0.4 % still at h = a quarter of it.
  const openvdb::math::Transform::Ptr xform = lattice_transform(voxel_size);
  openvdb::tools::QuadAndTriangleDataAdapter<openvdb::Vec3s, openvdb::Vec4I> mesh(points, quads);
  const float width = static_cast<float>(std::max(half_width, 2));
  auto impl = std::make_unique<VdbLevelSet>();
  impl->grid = openvdb::tools::meshToVolume<openvdb::FloatGrid>(mesh, *xform, width, width,
                                                                openvdb::tools::DISABLE_RENORMALIZATION);
  impl->h = voxel_size;
  return impl;
}

std::unique_ptr<VdbLevelSet> level_set_from_surface(const SurfaceMesh& surface, double voxel_size, int half_width) {
  if (!(voxel_size > 0)) throw std::invalid_argument("voxel size must be positive");
  if (surface.triangle_count() == 0) throw std::invalid_argument("cannot voxelise an empty surface");
  initialise_openvdb();
  std::vector<openvdb::Vec3s> points(static_cast<std::size_t>(surface.vertex_count()));
  for (std::size_t v = 0; v < points.size(); ++v)
    points[v] = openvdb::Vec3s(static_cast<float>(surface.vertices[3 * v]), static_cast<float>(surface.vertices[3 * v + 1]),
                               static_cast<float>(surface.vertices[3 * v + 2]));
  std::vector<openvdb::Vec3I> triangles(static_cast<std::size_t>(surface.triangle_count()));
  for (std::size_t t = 0; t < triangles.size(); ++t)
    triangles[t] = openvdb::Vec3I(static_cast<unsigned>(surface.triangles[3 * t]),
                                  static_cast<unsigned>(surface.triangles[3 * t + 1]),
                                  static_cast<unsigned>(surface.triangles[3 * t + 2]));
  const openvdb::math::Transform::Ptr xform = lattice_transform(voxel_size);
  auto impl = std::make_unique<VdbLevelSet>();
  impl->grid = openvdb::tools::meshToLevelSet<openvdb::FloatGrid>(*xform, points, triangles,
                                                                  static_cast<float>(std::max(half_width, 2)));
  impl->h = voxel_size;
  return impl;
}

std::unique_ptr<VdbLevelSet> level_set_between(const VdbLevelSet& a, const VdbLevelSet& b, double within,
                                               const std::function<double(const Vec3&)>& region) {
  const double h = a.voxel_size();
  if (std::abs(b.voxel_size() - h) > 1e-12 * h) throw std::invalid_argument("between: the organs' voxel sizes differ");
  if (!(within > 0)) throw std::invalid_argument("between: the distance must be positive");
  if (a.band() < within + 2 * h || b.band() < within + 2 * h)
    throw std::invalid_argument("between: the organs' level sets are narrower than the distance");
  const float d = static_cast<float>(within), background = static_cast<float>(3 * h);
  const openvdb::FloatGrid& ga = *a.grid;
  const openvdb::FloatGrid& gb = *b.grid;
  // Candidates: the overlap of the two active boxes (each covers its organ dilated by its band).
  openvdb::CoordBBox box = ga.evalActiveVoxelBoundingBox();
  box.intersect(gb.evalActiveVoxelBoundingBox());
  auto impl = std::make_unique<VdbLevelSet>();
  impl->h = h;
  impl->grid = openvdb::FloatGrid::create(background);
  impl->grid->setTransform(lattice_transform(h));
  impl->grid->setGridClass(openvdb::GRID_LEVEL_SET);
  long long inside = 0;
  if (!box.empty()) {
    auto acc_a = ga.getConstAccessor();
    auto acc_b = gb.getConstAccessor();
    auto out = impl->grid->getAccessor();
    for (int x = box.min().x(); x <= box.max().x(); ++x)
      for (int y = box.min().y(); y <= box.max().y(); ++y)
        for (int z = box.min().z(); z <= box.max().z(); ++z) {
          const openvdb::Coord c(x, y, z);
          const float pa = acc_a.getValue(c), pb = acc_b.getValue(c);
          float phi = std::max({pa - d, pb - d, -pa, -pb});
          if (region && phi < background) phi = std::max(phi, static_cast<float>(region(Vec3{x * h, y * h, z * h})));
          if (phi >= background) continue;
          out.setValue(c, std::max(phi, -background));
          if (phi < 0) ++inside;
        }
  }
  if (inside == 0)
    throw std::invalid_argument(region ? "between: no point of the region lies within the distance of both organs outside them"
                                       : "between: no point lies within the distance of both organs outside them");
  return impl;
}

struct VdbProbe final : VoxelDomain::Probe::Impl {
  VdbProbe(const openvdb::FloatGrid& grid, double h) : accessor(grid.getConstUnsafeAccessor()), inverse_h(1 / h) {}
  double signed_distance(const Vec3& x) override { return interpolate(accessor, x, inverse_h); }
  openvdb::FloatGrid::ConstUnsafeAccessor accessor;
  double inverse_h;
};

struct VdbDomain final : VoxelDomain::Impl {
  openvdb::FloatGrid::ConstPtr grid;  // shared with the level set, never modified
  double h = 0;
  openvdb::CoordBBox box;  // index box holding every covered voxel

  double voxel_size() const override { return h; }

  Vec3 lower() const override {
    const openvdb::Coord c = box.min();
    return Vec3{(c.x() - 0.5) * h, (c.y() - 0.5) * h, (c.z() - 0.5) * h};
  }

  Vec3 upper() const override {
    const openvdb::Coord c = box.max();
    return Vec3{(c.x() + 0.5) * h, (c.y() + 0.5) * h, (c.z() + 0.5) * h};
  }

  double signed_distance(const Vec3& x) const override {
    const auto acc = grid->getConstUnsafeAccessor();
    return interpolate(acc, x, 1 / h);
  }

  std::unique_ptr<VoxelDomain::Probe::Impl> probe() const override { return std::make_unique<VdbProbe>(*grid, h); }

  int slice_count() const override { return box.empty() ? 0 : box.max().z() - box.min().z() + 1; }

  void covered_voxels(int k, std::vector<CoveredVoxel>& out) const override {
    const auto acc = grid->getConstUnsafeAccessor();
    const int z = box.min().z() + k;
    for (int x = box.min().x(); x <= box.max().x(); ++x)
      for (int y = box.min().y(); y <= box.max().y(); ++y) {
        const double phi = acc.getValue(openvdb::Coord(x, y, z));
        const double fraction = std::min(1.0, 0.5 - phi / h);
        if (fraction > 0) out.push_back(CoveredVoxel{Vec3{x * h, y * h, z * h}, fraction});
      }
  }
};

struct OpenVdbModule final : VoxelModule {
  std::unique_ptr<LevelSet::Impl> from_labels(const LabelImage& image, const std::vector<int>& labels,
                                              double voxel_size, int half_width) const override {
    return level_set_from_labels(image, labels, voxel_size, half_width);
  }
  std::unique_ptr<LevelSet::Impl> from_surface(const SurfaceMesh& surface, double voxel_size,
                                               int half_width) const override {
    return level_set_from_surface(surface, voxel_size, half_width);
  }
  std::unique_ptr<LevelSet::Impl> between(const LevelSet::Impl& a, const LevelSet::Impl& b, double within,
                                          const std::function<double(const Vec3&)>& region) const override {
    return level_set_between(static_cast<const VdbLevelSet&>(a), static_cast<const VdbLevelSet&>(b), within, region);
  }
  int smoothing_band(double standard_deviation, double voxel_size) const override {
    return std::max(3, box_passes(standard_deviation, voxel_size).width + 2);
  }
  std::unique_ptr<VoxelDomain::Impl> domain(const LevelSet::Impl& level_set) const override {
    auto impl = std::make_unique<VdbDomain>();
    impl->grid = static_cast<const VdbLevelSet&>(level_set).grid;
    impl->h = level_set.voxel_size();
    impl->box = impl->grid->evalActiveVoxelBoundingBox();
    return impl;
  }
};

}  // namespace
}  // namespace fascia

extern "C" const fascia::VoxelModule* fascia_voxel_module() {
  static const fascia::OpenVdbModule module;
  return &module;
}
