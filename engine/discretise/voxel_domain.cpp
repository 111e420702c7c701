#include "discretise/voxel_domain.hpp"

#include "discretise/level_set_grid.hpp"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <algorithm>
#include <stdexcept>

namespace fascia {

struct VoxelDomain::Impl {
  openvdb::FloatGrid::Ptr grid;
  double h = 0;
  openvdb::CoordBBox box;  // index box holding every covered voxel
};

struct VoxelDomain::Probe::Impl {
  explicit Impl(const openvdb::FloatGrid& grid) : accessor(grid.getConstUnsafeAccessor()), inverse_h(0) {}
  openvdb::FloatGrid::ConstUnsafeAccessor accessor;
  double inverse_h;
};

namespace {

// Trilinear interpolation of the grid at world point x (voxel centres at h * index).
template <class Accessor>
double interpolate(const Accessor& acc, const Vec3& x, double inverse_h) {
  const openvdb::Vec3d index(x.x * inverse_h, x.y * inverse_h, x.z * inverse_h);
  return openvdb::tools::BoxSampler::sample(acc, index);
}

}  // namespace

VoxelDomain::VoxelDomain(const SurfaceMesh& surface, double voxel_size, int half_width)
    : VoxelDomain(LevelSet::from_surface(surface, voxel_size, half_width)) {}

VoxelDomain::VoxelDomain(const LevelSet& level_set) : m_impl(new Impl) {
  m_impl->grid = level_set.impl().grid;  // shared, never modified
  m_impl->h = level_set.voxel_size();
  m_impl->box = m_impl->grid->evalActiveVoxelBoundingBox();
}

VoxelDomain::~VoxelDomain() = default;
VoxelDomain::VoxelDomain(VoxelDomain&&) noexcept = default;
VoxelDomain& VoxelDomain::operator=(VoxelDomain&&) noexcept = default;

double VoxelDomain::voxel_size() const { return m_impl->h; }

Vec3 VoxelDomain::lower() const {
  const openvdb::Coord c = m_impl->box.min();
  const double h = m_impl->h;
  return Vec3{(c.x() - 0.5) * h, (c.y() - 0.5) * h, (c.z() - 0.5) * h};
}

Vec3 VoxelDomain::upper() const {
  const openvdb::Coord c = m_impl->box.max();
  const double h = m_impl->h;
  return Vec3{(c.x() + 0.5) * h, (c.y() + 0.5) * h, (c.z() + 0.5) * h};
}

double VoxelDomain::signed_distance(const Vec3& x) const {
  const auto acc = m_impl->grid->getConstUnsafeAccessor();
  return interpolate(acc, x, 1 / m_impl->h);
}

VoxelDomain::Probe::Probe(const VoxelDomain& domain) : m_impl(new Impl(*domain.m_impl->grid)) {
  m_impl->inverse_h = 1 / domain.m_impl->h;
}
VoxelDomain::Probe::~Probe() = default;

double VoxelDomain::Probe::signed_distance(const Vec3& x) { return interpolate(m_impl->accessor, x, m_impl->inverse_h); }

int VoxelDomain::slice_count() const {
  return m_impl->box.empty() ? 0 : m_impl->box.max().z() - m_impl->box.min().z() + 1;
}

void VoxelDomain::covered_voxels(int k, std::vector<CoveredVoxel>& out) const {
  const auto acc = m_impl->grid->getConstUnsafeAccessor();
  const openvdb::CoordBBox& b = m_impl->box;
  const double h = m_impl->h;
  const int z = b.min().z() + k;
  for (int x = b.min().x(); x <= b.max().x(); ++x)
    for (int y = b.min().y(); y <= b.max().y(); ++y) {
      const double phi = acc.getValue(openvdb::Coord(x, y, z));
      const double fraction = std::min(1.0, 0.5 - phi / h);
      if (fraction > 0) out.push_back(CoveredVoxel{Vec3{x * h, y * h, z * h}, fraction});
    }
}

double VoxelDomain::volume() const {
  const int n = slice_count();
  std::vector<double> per_slice(n, 0.0);
#pragma omp parallel
  {
    std::vector<CoveredVoxel> voxels;
#pragma omp for schedule(dynamic, 4)
    for (int k = 0; k < n; ++k) {
      voxels.clear();
      covered_voxels(k, voxels);
      double v = 0;
      for (const CoveredVoxel& c : voxels) v += c.fraction;
      per_slice[k] = v;
    }
  }
  double total = 0;  // fixed order: independent of the thread count
  for (double v : per_slice) total += v;
  const double h = m_impl->h;
  return total * h * h * h;
}

long long VoxelDomain::covered_count() const {
  long long count = 0;
  std::vector<CoveredVoxel> voxels;
  for (int k = 0; k < slice_count(); ++k) {
    voxels.clear();
    covered_voxels(k, voxels);
    count += static_cast<long long>(voxels.size());
  }
  return count;
}

}  // namespace fascia
