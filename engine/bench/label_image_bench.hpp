// `fascia bench discretise --label-image N`: time to read a label image and voxelise each of its
// labels to a level set, with each label's volume against its voxel count x voxel volume.
#pragma once

#include "discretise/label_image.hpp"

#include <ostream>
#include <string>
#include <vector>

namespace fascia {

// A synthetic segmentation of n^3 voxels of 0.7 x 0.8 x 1.25 mm, turned by 0.4 rad about
// (1, -2, 0.5) (anisotropic and oblique, as a scanner's sform may be): label 1 an ellipsoid of
// semi-axes 70 x 50 x 45 voxels, 2 a ball of radius 20 voxels, 3 a box of 50 x 60 x 30 voxels,
// 4 a torus of radii 25 and 8 voxels (sizes for n = 256, scaled by n / 256), 0 elsewhere.
LabelImage label_image_phantom(int n);

struct LabelImageBenchRow {
  int label = 0;
  long long voxels = 0;         // voxels holding the label
  double seconds = 0;           // LevelSet::from_labels, wall
  double domain_error = 0;      // VoxelDomain::volume() / (voxels x voxel volume) - 1
  double level_set_error = 0;   // LevelSet::volume() (OpenVDB's measure) / (voxels x voxel volume) - 1
  double surface_error = 0;     // the boundary surface's enclosed volume / (voxels x voxel volume) - 1
};

struct LabelImageBench {
  std::string path;
  std::array<long long, 3> size{0, 0, 0};
  double lattice = 0;       // h, m: the smallest voxel edge
  double seconds_read = 0;  // read_label_image, wall
  double seconds_all = 0;   // LevelSet::from_labels of all labels at once, wall
  std::vector<LabelImageBenchRow> labels;
};

// Writes label_image_phantom(n) as a gzipped NIfTI-1 file at `path` (int16 voxels).
void write_label_image_phantom(const std::string& path, int n);

// Reads `path` and voxelises each non-zero label, and all of them together, on the lattice of
// spacing the image's smallest voxel edge.
LabelImageBench bench_label_image(const std::string& path);

void write_label_image_bench(std::ostream& out, const LabelImageBench& bench, bool json);

}  // namespace fascia
