// Small meshless models for the mechanics tests.
#pragma once

#include "discretise/meshless.hpp"

namespace fascia::test {

// The 0.2 x 0.1 x 0.05 m box of fixtures.hpp, discretised meshless (about 30 frames, 170 samples).
inline MeshlessBuild small_meshless_box(MaterialLaw law = MaterialLaw::stvk, std::uint64_t seed = 1) {
  MeshlessOptions options;
  options.frame_spacing = 0.04;
  options.sample_spacing = 0.018;
  options.seed = seed;
  return build_meshless_model(box_surface({0, 0, 0}, {0.2, 0.1, 0.05}), make_material(law, 1.0e4, 0.3, 1000.0),
                              options);
}

}  // namespace fascia::test
