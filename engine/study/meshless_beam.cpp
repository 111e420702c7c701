#include "study/meshless_beam.hpp"

#include <cmath>
#include <stdexcept>

namespace fascia {
namespace {

int cells(double extent, double spacing) { return std::max(1, static_cast<int>(std::ceil(extent / spacing - 1e-9))); }

}  // namespace

void meshless_beam_resolution(const BeamSettings& s, double frame_spacing, int& nx, int& ny, int& nz) {
  nx = cells(s.length, frame_spacing);
  ny = cells(s.width, frame_spacing);
  nz = cells(s.height, frame_spacing);
}

MeshlessBeam build_meshless_beam(const BeamSettings& s, double frame_spacing) {
  if (!(frame_spacing > 0)) throw std::invalid_argument("meshless beam: frame_spacing must be positive");
  if (!(s.samples_per_frame > 1)) throw std::invalid_argument("meshless beam: samples_per_frame must exceed 1");
  MeshlessOptions options;
  options.frame_spacing = frame_spacing;
  options.sample_spacing = frame_spacing / std::cbrt(s.samples_per_frame);
  options.seed = s.seed;
  int nx, ny, nz;
  meshless_beam_resolution(s, frame_spacing, nx, ny, nz);
  for (int j = 0; j <= ny; ++j)
    for (int k = 0; k <= nz; ++k)
      options.extra_frames.insert(options.extra_frames.end(), {0.0, s.width * j / ny, s.height * k / nz});

  const double density = s.mass / (s.length * s.width * s.height);
  MeshlessBuild build = build_meshless_model(box_surface({0, 0, 0}, {s.length, s.width, s.height}),
                                             make_material(s.law, s.young, s.poisson, density), options);
  MeshlessBeam beam{std::move(build.model), Probe{}, build.statistics, 0};
  // Grid frames sit exactly on x = 0; every Poisson or repair frame is off it.
  beam.clamped_frames = fix_frames(beam.model, [](double x, double, double) { return x == 0.0; });
  beam.tip = make_meshless_probe(build.shape, Vec3{s.length, 0.5 * s.width, 0.5 * s.height});
  return beam;
}

}  // namespace fascia
