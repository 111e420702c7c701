// The kernels tests' models and states (boxes of tetrahedra or hexahedra in random deformed
// states), and norm-wise relative differences.
#pragma once

#include "support/fixtures.hpp"

#include <cmath>
#include <random>
#include <vector>

namespace fascia::test {

// ||a - b|| / ||b|| (0 when both vanish).
inline double relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double num = 0, den = 0;
  for (size_t k = 0; k < b.size(); ++k) {
    num += (a[k] - b[k]) * (a[k] - b[k]);
    den += b[k] * b[k];
  }
  return den > 0 ? std::sqrt(num / den) : std::sqrt(num);
}

// A box of tetrahedra (4 neighbours per sample) or hexahedra (8), the x = 0 face fixed, in a
// random deformed state with random velocities.
// With MaterialLaw::hgo each sample has its own material (fibres k1 = 3 E, k2 = 5, dispersion
// 0.1 along a direction that turns from sample to sample), as a fibre field makes them: the
// device reads each sample's fibres through its material index, and the random states stretch
// some samples' fibres and shorten others'. `hgo` picks the law's variant: one family in the
// coupled form, or two at +-0.6 rad about that direction (in its plane with z) in the uncoupled
// form.
enum class HgoVariant { one_family_coupled, two_families_uncoupled };
inline const char* to_string(HgoVariant v) {
  return v == HgoVariant::one_family_coupled ? "one family, coupled" : "two families, uncoupled";
}
inline Model kernels_test_model(CellType type, MaterialLaw law, int nx = 4, int ny = 3, int nz = 2,
                                HgoVariant hgo = HgoVariant::one_family_coupled) {
  Model model = small_box_model(type, law == MaterialLaw::hgo ? MaterialLaw::neo_hookean : law, nx, ny, nz);
  if (law == MaterialLaw::hgo) {
    model.materials.clear();
    const bool two = hgo == HgoVariant::two_families_uncoupled;
    for (int s = 0; s < model.sample_count(); ++s) {
      const Vec3 a{std::cos(0.7 * s), std::sin(0.7 * s), 0.5 * std::cos(1.3 * s)};
      Fibres f{3.0e4, 5.0, 0.1, a};
      if (two) {
        f.families = 2;
        f.angle = 0.6;
        f.plane = Vec3{0, 0, 1};  // never along a: its x, y part has unit length
      }
      model.materials.push_back(make_hgo_material(1.0e4, 0.3, 1000.0, f,
                                                  two ? HgoFormulation::uncoupled : HgoFormulation::coupled));
      model.samples.materials[static_cast<size_t>(s)] = s;
    }
  }
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  return model;
}

// displacement (m): the bound of the positions' perturbation; 0.004 suits the 4 x 3 x 2-cell box
// (cells of 5 cm or more), finer boxes need it below their cell size.
inline State kernels_test_state(const Model& model, unsigned seed, double displacement = 0.004) {
  State s = random_state(model, seed, displacement, 0.2, 0.7);
  std::mt19937 rng(seed + 1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double& v : s.velocities) v = 0.05 * u(rng);
  return s;
}

}  // namespace fascia::test
