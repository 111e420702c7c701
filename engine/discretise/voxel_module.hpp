// The OpenVDB side of LevelSet and VoxelDomain: a module of its own (libfascia_openvdb.so,
// discretise/openvdb_voxels.cpp), loaded with dlopen on the first voxelisation of a process.
//
// OpenVDB and its libraries (TBB, Blosc, log4cplus, Boost.Iostreams, Imath) hold about three
// quarters of the symbol relocations a process of the engine would otherwise resolve at start-up
// (libopenvdb alone about 69,000 of 91,000), about 35 ms on a 2-core VM for every command, also
// for the scenes and commands that never voxelise. LevelSet and VoxelDomain forward to the
// interfaces below; only the module includes OpenVDB.
//
// The module is looked for in the folder FASCIA_MODULE_DIR names, else at ../lib from the running
// executable (the build tree's bin/ and lib/, and a bundle's), then in the build tree's lib/.
#pragma once

#include "discretise/level_set.hpp"
#include "discretise/voxel_domain.hpp"

#include <filesystem>
#include <functional>
#include <memory>
#include <vector>

namespace fascia {

struct LevelSet::Impl {
  virtual ~Impl() = default;
  virtual double voxel_size() const = 0;
  virtual double band() const = 0;
  virtual double volume() const = 0;
  virtual Vec3 gradient(const Vec3& x) const = 0;
  virtual SurfaceMesh surface() const = 0;
  virtual double smooth(double standard_deviation) = 0;
};

struct VoxelDomain::Probe::Impl {
  virtual ~Impl() = default;
  virtual double signed_distance(const Vec3& x) = 0;
};

struct VoxelDomain::Impl {
  virtual ~Impl() = default;
  virtual double voxel_size() const = 0;
  virtual Vec3 lower() const = 0;
  virtual Vec3 upper() const = 0;
  virtual double signed_distance(const Vec3& x) const = 0;
  virtual std::unique_ptr<Probe::Impl> probe() const = 0;
  virtual int slice_count() const = 0;
  virtual void covered_voxels(int k, std::vector<CoveredVoxel>& out) const = 0;
};

// The module's constructors, as LevelSet's and VoxelDomain's of the same names document them.
struct VoxelModule {
  virtual ~VoxelModule() = default;
  virtual std::unique_ptr<LevelSet::Impl> from_labels(const LabelImage& image, const std::vector<int>& labels,
                                                      double voxel_size, int half_width) const = 0;
  virtual std::unique_ptr<LevelSet::Impl> from_surface(const SurfaceMesh& surface, double voxel_size,
                                                       int half_width) const = 0;
  virtual std::unique_ptr<LevelSet::Impl> between(const LevelSet::Impl& a, const LevelSet::Impl& b, double within,
                                                  const std::function<double(const Vec3&)>& region) const = 0;
  virtual int smoothing_band(double standard_deviation, double voxel_size) const = 0;
  // A domain sharing the level set's grid (never modified through it).
  virtual std::unique_ptr<VoxelDomain::Impl> domain(const LevelSet::Impl& level_set) const = 0;
};

// The module file voxel_module() loads: the first of the places above that exists (empty: none).
// A checkpoint's build identity covers its bytes with the executable's.
std::filesystem::path voxel_module_file();

// The loaded module; loads it on the first call (thread-safe). Throws std::runtime_error naming
// the file and the loader's message where it cannot be loaded.
const VoxelModule& voxel_module();

}  // namespace fascia

// The module's one exported symbol: its VoxelModule (a static object).
extern "C" const fascia::VoxelModule* fascia_voxel_module();
