// A probe: a material point of a discretised object followed through the deformation with the
// same interpolation as the samples (eq. 3), e.g. the centre of a beam's free end.
#pragma once

#include "discretise/volume_mesh.hpp"
#include "model/state.hpp"
#include "shape/meshless_shape.hpp"

#include <vector>

namespace fascia {

struct Probe {
  std::vector<int> frames;
  std::vector<double> weights;
  std::vector<double> rest_offsets;  // [k][3] l = p - x_i at rest
  Vec3 rest_position{0, 0, 0};
};

// Locates the cell that contains point (tolerance 1e-9 relative in reference coordinates) and
// returns its interpolation; throws std::invalid_argument when the point is outside the mesh.
Probe make_probe(const VolumeMesh& mesh, const Vec3& point);

// The same for a meshless model: its shape functions (MeshlessBuild::shape) evaluated at an
// arbitrary rest point, e.g. on the surface where no sample lies; the fields are the ones the
// samples see. Throws std::invalid_argument when no frame covers the point or the shape functions
// cannot be built there (MLS with coplanar neighbours).
Probe make_meshless_probe(const MeshlessShape& shape, const Vec3& point);

// Current position p = sum_i w_i (x_i + R_i l_i), eq. (3).
Vec3 probe_position(const Probe& probe, const State& state);

}  // namespace fascia
