// The OpenVDB grid behind LevelSet, for the discretisation's sources only (voxel_domain.cpp,
// level_set.cpp): other modules see LevelSet and VoxelDomain without OpenVDB.
#pragma once

#include "discretise/level_set.hpp"

#include <openvdb/openvdb.h>

namespace fascia {

struct LevelSet::Impl {
  openvdb::FloatGrid::Ptr grid;  // linear transform of voxel size h; background = band (m)
  double h = 0;
};

// openvdb::initialize(), once per process.
void initialise_openvdb();

}  // namespace fascia
