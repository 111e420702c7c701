// Meshless discretisation from a closed surface mesh (paper §2.1): voxelise the surface with
// OpenVDB, place frames and samples by two Poisson-disk samplings (radii r_f > r_s), give each
// sample the volume of the voxels nearest to it, attach each sample to its neighbour frames with
// meshless shape functions (shape/meshless_shape.hpp: one conforming field per frame), and make
// the sample integration variationally consistent (shape/consistent_integration.hpp: boundary
// integrals on the surface mesh with surface_quadrature at spacing r_s).
//
// Thin parts. A sheet thinner than r_f (typical of fasciae) holds a single layer of frames, so a
// sample's neighbour frames are nearly coplanar: MLS becomes singular and the gradient across
// the sheet is not controlled. A sample is well supported when neighbour_spread >= min_spread
// (the kernel-weighted frame cloud is at least that fraction as wide across its thinnest
// direction as along its widest). With ThinParts::repair, each badly supported sample proposes
// two extra frames at p +- r_f n (n = the thinnest direction), kept when at least r_f/2 from the
// Poisson frames and r_f from other extra frames; these frames lie outside the sheet, which the
// frame method allows (frames are control points; their mass comes from the samples' weights).
// With ThinParts::stop, or when repair does not succeed, the build throws a message naming the
// region, the local thickness and the frame spacing that would resolve it.
//
// Frame lattice. The frames are the degrees of freedom, the samples a quadrature: refining
// sample_spacing must not move the frames. The frames' Poisson-disk set is drawn on the boundary
// surface voxelised at frame_lattice_spacing(r_f), which depends on r_f only, so a given surface,
// r_f, seed and extra_frames give bitwise the same Poisson frames whatever r_s and voxel_size
// (thin-part repair frames, which follow the samples, and frames no sample uses excepted). The
// samples and their volumes use the lattice h = voxel_size (default r_s / 2).
#pragma once

#include "discretise/surface_mesh.hpp"
#include "model/model.hpp"
#include "shape/meshless_shape.hpp"

#include <cstdint>
#include <string>

namespace fascia {

enum class ThinParts { repair, stop };

struct MeshlessOptions {
  double frame_spacing = 0;   // r_f, m: minimum distance between frames
  double sample_spacing = 0;  // r_s, m: minimum distance between samples, 0 < r_s < r_f
  double voxel_size = 0;      // h, m, of the samples' lattice; 0: r_s / 2 (frames: see above)
  MeshlessShapeOptions shape;
  std::uint64_t seed = 1;     // frames use seed, samples a stream derived from it
  ThinParts thin_parts = ThinParts::repair;
  double min_spread = 0.15;   // see above; 0 disables the check (MLS singularities still fail)
  int repair_passes = 3;
  // Frames placed by the caller, [K][3] m, e.g. a grid on a clamped face: Dirichlet conditions
  // fix frames, and Poisson-disk frames (all strictly inside) sit up to r_f from the boundary.
  // Poisson-disk frames keep at least r_f from these (poisson_disk.hpp, prescribed points): a frame
  // just inside a clamped face would leave the face's material free to move around it.
  std::vector<double> extra_frames;
  bool require_closed_surface = true;  // throw on holes, flipped or self-intersecting faces
};

struct MeshlessStatistics {
  int frames = 0;
  int samples = 0;
  int added_frames = 0;    // thin-part repair frames (included in `frames`)
  int neighbours_min = 0;  // frames per sample
  double neighbours_mean = 0;
  int neighbours_max = 0;
  double min_spread = 0;   // smallest neighbour_spread over samples
  double voxel_size = 0;   // m, the samples' lattice
  double frame_voxel_size = 0;  // m, the frames' lattice, frame_lattice_spacing(r_f)
  long long voxels = 0;    // covered voxels
  double surface_volume = 0;  // m^3, divergence theorem on the boundary surface
  double voxel_volume = 0;    // m^3, sum of covered voxel fractions
  double unassigned_volume = 0;  // m^3, voxels with no sample in reach (thinner than a voxel)
  double volume_error = 0;    // (voxel_volume - surface_volume) / surface_volume, before scaling
  // The sample volumes are scaled to the enclosed volume of the boundary surface (divergence
  // theorem, exact for the triangulation), which consistent integration requires; the coverage
  // ramp of the voxelisation rounds convex edges (about +0.13 h^2 per metre of 90-degree edge).
  double volume_scale = 1;    // factor applied to the voxel shares
  double sample_volume = 0;   // m^3, sum of the final sample volumes
  double support_min = 0, support_max = 0;  // m, frame supports rho_i
  long long boundary_points = 0;            // surface quadrature points
  double integration_defect_before = 0;     // consistent_integration.hpp, relative
  double integration_defect = 0;            // after the correction
  int integration_iterations = 0;
  // Wall seconds of the stages (disjoint parts of the total, which has the checks besides).
  double seconds_voxelise = 0, seconds_frames = 0, seconds_samples = 0, seconds_volumes = 0,
         seconds_shape = 0, seconds_integration = 0, seconds_total = 0;

  // Multi-line human-readable summary (`fascia check`).
  std::string describe() const;
};

struct MeshlessBuild {
  Model model;
  MeshlessShape shape;  // the model's frames and supports: evaluates the fields at other points
  MeshlessStatistics statistics;
};

// The voxel size of the lattice the frames are drawn on, m: r_f / (2 cbrt 10), half the sample
// spacing at ten samples per frame (the beam study's default), where the two lattices coincide
// and one voxelisation serves both. About r_f / 4.3: interior lattice points seed frames in
// sheets down to about a quarter of r_f thick; thinner ones get thin-part repair frames.
double frame_lattice_spacing(double frame_spacing);

// Builds frames, samples (one material), neighbour and reverse tables, frame masses; all frames
// free. Throws std::invalid_argument on bad options or surface, std::runtime_error on thin parts
// that cannot be resolved.
MeshlessBuild build_meshless_model(const SurfaceMesh& surface, const Material& material, const MeshlessOptions& options);

class VoxelDomain;
// The same on a voxelised domain (a label image, a region derived from other objects) bounded by
// `boundary`, a closed triangle surface of the same domain (for a level set, its zero surface,
// LevelSet::surface): the domain's voxel size replaces options.voxel_size, the frames are drawn
// on the boundary voxelised at frame_lattice_spacing(r_f) (so they follow the resolved geometry
// of the domain, not its lattice), the boundary carries
// the surface rule of the consistent integration, and its enclosed volume is the one the sample
// volumes are scaled to (surface_volume, volume_error). Either orientation of the triangles.
MeshlessBuild build_meshless_model(const VoxelDomain& domain, const SurfaceMesh& boundary, const Material& material,
                                   const MeshlessOptions& options);

}  // namespace fascia
