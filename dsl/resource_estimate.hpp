// What a scene will ask of the machine, estimated before anything large is allocated: memory
// for each object's discretisation (frames, samples, voxels, point grids, mesh rows) against
// --max-memory, and disk for the output's preallocated rows against the free space. A scene
// beyond a limit is refused (ExitCode::too_large) with the scene value that asks for it, the
// estimate and the likely cause, instead of ending in std::bad_alloc or the OOM killer.
//
// The estimates are orders of magnitude, not budgets: their constants (bytes per sample, per
// frame, per voxel) are rounded up from the data structures they stand for, so a scene that fits
// is never refused and one that asks for 100x the machine is refused in milliseconds.
#pragma once

#include "core/bytes_text.hpp"
#include "discretise/label_image.hpp"
#include "discretise/meshless.hpp"
#include "discretise/surface_mesh.hpp"
#include "dsl/diagnostics.hpp"

#include <string>

namespace fascia::dsl {

struct ResourceLimits {
  double max_memory = 0;  // bytes; <= 0: machine_memory()
};

// The machine's physical memory, or the cgroup's limit (Slurm jobs) when that is lower, bytes.
double machine_memory();

// "16G", "512 MiB", "2GB", "1e9" (bytes; K, M, G, T are powers of 1024) -> bytes, or < 0.
double parse_bytes(const std::string& text);

// Estimated figures of one object's discretisation.
struct ObjectEstimate {
  double frames = 0, samples = 0, voxels = 0;
  double bytes = 0;
  std::string cause;  // the likely cause when it is large ("" when nothing stands out)
};

// A meshless tissue from a closed surface (world axes, after its transform).
ObjectEstimate estimate_meshless(const SurfaceMesh& surface, const MeshlessOptions& options);

// The narrow-band level set of a closed surface (world axes) on the lattice of spacing
// voxel_size (m) with a band of half_width voxels each side: an organ voxelised for a tissue
// between organs.
ObjectEstimate estimate_level_set(const SurfaceMesh& surface, double voxel_size, int half_width);

// The narrow-band level set of the voxels of `image` holding one of `labels` (LevelSet::
// from_labels), from the area of the faces between a selected voxel and an unselected one.
ObjectEstimate estimate_label_level_set(const LabelImage& image, const std::vector<int>& labels, double voxel_size,
                                        int half_width);

// A mesh-based tissue of `cells` cells (`nodes` per cell, hexahedra 8, tetrahedra 4), `vertices`
// vertices, `samples_per_cell` quadrature points, spanning `extent` metres.
ObjectEstimate estimate_mesh_based(double cells, int nodes, double vertices, int samples_per_cell, double extent);

// Memory to read a mesh file of `file_bytes` bytes (the parsed text, the importer's copies).
double mesh_file_bytes(double file_bytes);

// Bytes of an output file: `rows` preallocated rows of `bytes_per_row` bytes.
double output_bytes(double rows, double bytes_per_row);

// Free bytes on the file system holding `path` (its directory when it does not exist yet), or
// < 0 when unknown.
double free_disk_bytes(const std::string& path);

}  // namespace fascia::dsl
