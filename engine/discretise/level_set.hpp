// Narrow-band signed distance fields on an axis-aligned lattice of spacing h (voxel centres at
// h * index, world axes, metres; negative inside), held by OpenVDB: the geometric domain that
// VoxelDomain answers inside tests and voxel coverage from.
//
// Built straight from a label image: the object is the union of the image's voxels that hold
// one of its labels (oblique, anisotropic voxels placed by the image's affine map), and OpenVDB
// computes exact distances to its boundary, the faces between a selected voxel and an unselected
// one, on the world lattice (tools::meshToVolume with those faces as quads, without its
// renormalisation). No surface is reconstructed or smoothed: the domain holds the voxels' volume
// (count times voxel volume) up to the coverage ramp's error at the staircase's edges, within
// 1 % at h = the smallest voxel edge (docs/meshless.md, "Label images").
//
// OpenVDB stays behind this interface (pimpl): its module is loaded on first use
// (discretise/voxel_module.hpp).
#pragma once

#include "core/small_math.hpp"
#include "discretise/label_image.hpp"
#include "discretise/surface_mesh.hpp"

#include <functional>
#include <memory>
#include <vector>

namespace fascia {

class LevelSet {
 public:
  struct Impl;

  // The union of the voxels of `image` holding one of `labels`, on the lattice of spacing
  // voxel_size (m), with exact distances within half_width lattice voxels of the surface (>= 2).
  // Throws std::invalid_argument when no voxel holds one of the labels or voxel_size <= 0.
  static LevelSet from_labels(const LabelImage& image, const std::vector<int>& labels, double voxel_size,
                              int half_width = 3);
  // The inside of a closed surface (tools::meshToLevelSet, sign by flood fill).
  static LevelSet from_surface(const SurfaceMesh& surface, double voxel_size, int half_width = 3);

  // Connective tissue between two organs (paper §4.2): the points within `within` (m) of both a
  // and b and inside neither, phi = max(phi_a - d, phi_b - d, -phi_a, -phi_b) (level-set CSG:
  // intersection of the dilated organs minus the organs), and inside `region` when one is given:
  // its signed distance (m, negative inside) joins the max. a and b share the voxel size and have
  // bands wider than within + 2 h. The result is a distance bound, exact away from its creases,
  // stored densely over its bounding box with a band of 3 voxels. Throws std::invalid_argument
  // on mismatched inputs or when the tissue is empty.
  static LevelSet between(const LevelSet& a, const LevelSet& b, double within,
                          const std::function<double(const Vec3&)>& region = nullptr);

  // Smooths the zero level set: repeated mean-value (box) filters of the distances, each followed
  // by OpenVDB's renormalisation, with a combined variance as close to standard_deviation^2 (m^2)
  // as the lattice allows: n passes of width 2w + 1 voxels have variance n w (w + 1) / 3 h^2
  // (n <= 8 and w chosen for the nearest variance). Features thinner than
  // about the standard deviation fade, and a convex part's boundary moves inward by about
  // standard_deviation^2 times its mean curvature. Needs a band of at least w + 2 voxels (see
  // smoothing_band). Returns the standard deviation realised, m (0 when standard_deviation = 0).
  double smooth(double standard_deviation);
  // The band half width, in voxels of size voxel_size, that smooth(standard_deviation) needs.
  static int smoothing_band(double standard_deviation, double voxel_size);

  explicit LevelSet(std::unique_ptr<Impl> impl);
  ~LevelSet();
  LevelSet(LevelSet&&) noexcept;
  LevelSet& operator=(LevelSet&&) noexcept;

  double voxel_size() const;
  // Half width of the band of exact distances, m.
  double band() const;
  // Enclosed volume of the zero level set, m^3 (OpenVDB's tools::levelSetVolume, from the
  // polygonised surface).
  double volume() const;
  // The gradient of the signed distance at world point x (m), by central differences of its
  // trilinear interpolation over one voxel on each axis: a unit vector pointing away from the
  // object where x and its neighbours lie within the band, zero beyond it (the band's constant).
  Vec3 gradient(const Vec3& x) const;
  // The zero level set as a closed triangle surface (tools::volumeToMesh, quads split along
  // their shorter diagonal), m: the boundary of the object for output and couplings.
  SurfaceMesh surface() const;

  const Impl& impl() const { return *m_impl; }

 private:
  std::unique_ptr<Impl> m_impl;
};

}  // namespace fascia
