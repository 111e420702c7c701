#include "discretise/sample_volumes.hpp"

#include "discretise/point_grid.hpp"

#include <cmath>
#include <stdexcept>

namespace fascia {

SampleVolumes sample_volumes(const VoxelDomain& domain, const std::vector<double>& samples, double radius) {
  const int s_count = static_cast<int>(samples.size() / 3);
  const double h = domain.voxel_size();
  const double cell = radius / std::sqrt(3.0);
  const double reach_distance = radius + 2 * h;
  // Offsets whose lower bound is below reach_distance: gap <= reach_distance / cell.
  const int reach = 1 + static_cast<int>(std::ceil(reach_distance / cell));
  PointGrid grid(domain.lower(), domain.upper(), cell, reach);
  for (int s = 0; s < s_count; ++s) {
    const long long c = grid.cell_of(load3(&samples[3 * s]));
    if (c < 0 || grid.at(c) >= 0)
      throw std::invalid_argument("sample_volumes: samples must lie in the domain and be at least `radius` apart");
    grid.set(c, s);
  }
  const int n = domain.slice_count();
  // Per-slice lists of (sample, volume) so that the final sums run in a fixed order.
  std::vector<std::vector<std::pair<int, double>>> shares(n);
  std::vector<double> lost(n, 0.0);
  const double voxel_volume = h * h * h;
#pragma omp parallel
  {
    std::vector<CoveredVoxel> voxels;
#pragma omp for schedule(dynamic, 2)
    for (int k = 0; k < n; ++k) {
      voxels.clear();
      domain.covered_voxels(k, voxels);
      auto& out = shares[k];
      out.reserve(voxels.size());
      int last = -1;
      double run = 0;
      for (const CoveredVoxel& v : voxels) {
        double d2;
        const int s = grid.nearest(v.centre, samples, d2);
        const double vol = v.fraction * voxel_volume;
        if (s < 0 || d2 > reach_distance * reach_distance) {
          lost[k] += vol;
          continue;
        }
        if (s != last && last >= 0) out.emplace_back(last, run), run = 0;
        last = s;
        run += vol;
      }
      if (last >= 0) out.emplace_back(last, run);
    }
  }
  SampleVolumes result;
  result.volumes.assign(s_count, 0.0);
  for (int k = 0; k < n; ++k) {
    for (const auto& [s, v] : shares[k]) result.volumes[s] += v;
    result.unassigned += lost[k];
  }
  for (double v : result.volumes) result.assigned += v;
  return result;
}

}  // namespace fascia
