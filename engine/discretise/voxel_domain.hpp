// Voxelisation of a closed surface with OpenVDB (paper §2.1, "using a voxelization of this
// mesh"): a narrow-band signed distance field (tools::meshToLevelSet, exact closest-triangle
// distances, sign by flood fill so independent of triangle orientation) answers inside tests and
// gives each voxel the fraction of it that lies inside.
//
// OpenVDB stays behind this interface (pimpl): its module is loaded on first use
// (discretise/voxel_module.hpp).
#pragma once

#include "core/small_math.hpp"
#include "discretise/level_set.hpp"
#include "discretise/surface_mesh.hpp"

#include <memory>
#include <vector>

namespace fascia {

// A voxel that the object covers at least partly. Centres lie on the lattice h i (i integer).
struct CoveredVoxel {
  Vec3 centre;      // m
  double fraction;  // in (0, 1]: share of the voxel inside the object
};

class VoxelDomain {
 public:
  struct Impl;  // discretise/voxel_module.hpp
  // @param voxel_size h, m. @param half_width narrow band half width in voxels (>= 2).
  // Throws std::invalid_argument when the mesh is empty or h <= 0.
  VoxelDomain(const SurfaceMesh& surface, double voxel_size, int half_width = 3);
  // Any level set (a label image's, a derived region's).
  explicit VoxelDomain(const LevelSet& level_set);
  ~VoxelDomain();
  VoxelDomain(VoxelDomain&&) noexcept;
  VoxelDomain& operator=(VoxelDomain&&) noexcept;

  double voxel_size() const;
  // Bounds of the voxels that may be covered (voxel faces), m.
  Vec3 lower() const;
  Vec3 upper() const;

  // Signed distance at x by trilinear interpolation of the grid, m (negative inside). Beyond the
  // narrow band the magnitude saturates at half_width * h. Thread-safe.
  double signed_distance(const Vec3& x) const;
  bool inside(const Vec3& x) const { return signed_distance(x) < 0; }

  // The same interpolation through a cached tree accessor, for hot loops; one per thread.
  class Probe {
   public:
    struct Impl;  // discretise/voxel_module.hpp
    explicit Probe(const VoxelDomain& domain);
    ~Probe();
    double signed_distance(const Vec3& x);
    bool inside(const Vec3& x) { return signed_distance(x) < 0; }

   private:
    std::unique_ptr<Impl> m_impl;
  };

  // Voxel slices along z: slice k holds the voxels of index z = first_slice() + k. Each call uses
  // its own accessor, so slices can be read in parallel.
  int slice_count() const;
  // Appends the covered voxels of slice k in x-major, y-minor order. The inside fraction of a
  // voxel with centre distance phi is clamp(1/2 - phi / h, 0, 1): exact for a plane parallel to
  // a voxel face, first-order-exact on average for any plane (the ramp and the true coverage
  // profile have the same integral), so summed volumes converge as O(h^2) for smooth surfaces.
  void covered_voxels(int k, std::vector<CoveredVoxel>& out) const;

  // Sum of fraction * h^3 over all covered voxels, m^3 (OpenMP over slices).
  double volume() const;
  // Number of covered voxels.
  long long covered_count() const;

 private:
  std::unique_ptr<Impl> m_impl;
};

}  // namespace fascia
