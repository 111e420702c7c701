#include "bench/discretise_bench.hpp"

#include <omp.h>

#include <cmath>
#include <iomanip>

namespace fascia {

DiscretiseBenchRow bench_discretise_once(long target, const DiscretiseBenchOptions& options) {
  const double volume = 4.0;
  DiscretiseBenchRow row;
  row.target = target;
  row.sample_spacing = std::cbrt(volume / (1.66 * static_cast<double>(target)));
  row.frame_spacing = row.sample_spacing * std::cbrt(10.0);
  MeshlessOptions m;
  m.sample_spacing = row.sample_spacing;
  m.frame_spacing = row.frame_spacing;
  m.shape.support_neighbours = options.neighbours;
  m.seed = options.seed;
  const SurfaceMesh box = box_surface({0, 0, 0}, {4, 1, 1});
  const MeshlessBuild build = build_meshless_model(box, make_material(MaterialLaw::stvk, 4e4, 0.3, 1000), m);
  row.statistics = build.statistics;
  return row;
}

void write_bench_row(std::ostream& out, const DiscretiseBenchRow& row, bool json) {
  const MeshlessStatistics& s = row.statistics;
  if (json) {
    out << std::setprecision(6) << "{\"samples\": " << s.samples << ", \"frames\": " << s.frames
        << ", \"seconds\": " << s.seconds_total << ", \"target_samples\": " << row.target
        << ", \"sample_spacing\": " << row.sample_spacing << ", \"frame_spacing\": " << row.frame_spacing
        << ", \"voxels\": " << s.voxels << ", \"neighbours_mean\": " << s.neighbours_mean
        << ", \"threads\": " << omp_get_max_threads() << ", \"stages\": {\"voxelise\": " << s.seconds_voxelise
        << ", \"frames\": " << s.seconds_frames << ", \"samples\": " << s.seconds_samples
        << ", \"volumes\": " << s.seconds_volumes << ", \"shape_functions\": " << s.seconds_shape
        << ", \"consistent_integration\": " << s.seconds_integration << "}, \"volume_error\": " << s.volume_error
        << "}\n";
  } else {
    out << std::setprecision(4) << s.samples << " samples, " << s.frames << " frames: " << s.seconds_total
        << " s (voxelise " << s.seconds_voxelise << ", frames " << s.seconds_frames << ", samples "
        << s.seconds_samples << ", volumes " << s.seconds_volumes << ", shape functions " << s.seconds_shape
        << ", consistent integration " << s.seconds_integration << "; " << s.voxels << " voxels, "
        << omp_get_max_threads() << " threads)\n";
  }
  out.flush();
}

}  // namespace fascia
