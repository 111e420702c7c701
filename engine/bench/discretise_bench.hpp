// `fascia bench discretise`: time to build a meshless model (voxelisation, frames, samples,
// volumes, shape functions) from a surface mesh, for a range of sample counts.
#pragma once

#include "discretise/meshless.hpp"

#include <ostream>
#include <vector>

namespace fascia {

struct DiscretiseBenchOptions {
  std::vector<long> sample_counts{10000, 100000, 1000000};  // targets, about 10 samples per frame
  int neighbours = MeshlessShapeOptions{}.support_neighbours;
  std::uint64_t seed = 1;
};

struct DiscretiseBenchRow {
  long target = 0;
  double sample_spacing = 0, frame_spacing = 0;  // m
  MeshlessStatistics statistics;                 // counts and per-stage seconds
};

// The object is a 4 x 1 x 1 m box surface (12 triangles); r_s is chosen so that a maximal
// Poisson-disk set holds about `target` samples (1.66 r_s^3 per sample, measured at 10^6) and
// r_f = r_s * 10^(1/3) gives about target / 10 frames.
DiscretiseBenchRow bench_discretise_once(long target, const DiscretiseBenchOptions& options);

// One line per row: JSON objects {"samples", "frames", "seconds", ...} when `json`, else text.
void write_bench_row(std::ostream& out, const DiscretiseBenchRow& row, bool json);

}  // namespace fascia
