#include "discretise/voxel_domain.hpp"

#include "discretise/voxel_module.hpp"

namespace fascia {

VoxelDomain::VoxelDomain(const SurfaceMesh& surface, double voxel_size, int half_width)
    : VoxelDomain(LevelSet::from_surface(surface, voxel_size, half_width)) {}

VoxelDomain::VoxelDomain(const LevelSet& level_set) : m_impl(voxel_module().domain(level_set.impl())) {}

VoxelDomain::~VoxelDomain() = default;
VoxelDomain::VoxelDomain(VoxelDomain&&) noexcept = default;
VoxelDomain& VoxelDomain::operator=(VoxelDomain&&) noexcept = default;

double VoxelDomain::voxel_size() const { return m_impl->voxel_size(); }
Vec3 VoxelDomain::lower() const { return m_impl->lower(); }
Vec3 VoxelDomain::upper() const { return m_impl->upper(); }
double VoxelDomain::signed_distance(const Vec3& x) const { return m_impl->signed_distance(x); }

VoxelDomain::Probe::Probe(const VoxelDomain& domain) : m_impl(domain.m_impl->probe()) {}
VoxelDomain::Probe::~Probe() = default;
double VoxelDomain::Probe::signed_distance(const Vec3& x) { return m_impl->signed_distance(x); }

int VoxelDomain::slice_count() const { return m_impl->slice_count(); }

void VoxelDomain::covered_voxels(int k, std::vector<CoveredVoxel>& out) const { m_impl->covered_voxels(k, out); }

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
  const double h = voxel_size();
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
