// Sample volumes v_s that partition the voxelised object: each covered voxel gives its inside
// volume (fraction * h^3, see VoxelDomain::covered_voxels) to the nearest sample. The volumes
// therefore sum to VoxelDomain::volume(), the quadrature weights of W = sum_s v_s psi(F_s).
#pragma once

#include "discretise/voxel_domain.hpp"

#include <vector>

namespace fascia {

struct SampleVolumes {
  std::vector<double> volumes;  // [S] m^3
  double assigned = 0;          // sum of volumes, m^3
  double unassigned = 0;        // inside volume of voxels with no sample within reach, m^3
};

// @param samples [S][3] Poisson-disk points with minimum distance `radius` (m), inside the domain.
// Nearest samples are looked up in a grid of cells radius / sqrt(3) up to `radius` + 2 h away
// (a maximal Poisson-disk set leaves no inside voxel centre farther than `radius`); voxels farther
// than that count as unassigned. Parallel over voxel slices with OpenMP; deterministic.
SampleVolumes sample_volumes(const VoxelDomain& domain, const std::vector<double>& samples, double radius);

}  // namespace fascia
