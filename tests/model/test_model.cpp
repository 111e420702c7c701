// The model's derived tables (model/model.hpp): lumped frame masses and inertias.
#include "model/model.hpp"
#include "support/fixtures.hpp"
#include "support/meshless_fixtures.hpp"

#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>

#include <algorithm>

using namespace fascia;
using namespace fascia::test;

namespace {

double sample_mass_sum(const Model& model) {
  double m = 0;
  for (int s = 0; s < model.sample_count(); ++s)
    m += model.materials[model.samples.materials[s]].density * model.samples.volumes[s];
  return m;
}

// Smallest eigenvalue of frame i's lumped inertia (kg m^2) and its largest one.
std::pair<double, double> inertia_range(const Model& model, int i) {
  Eigen::Matrix3d I;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) I(r, c) = model.frame_inertias[9 * i + 3 * r + c];
  REQUIRE((I - I.transpose()).cwiseAbs().maxCoeff() <= 1e-15 * I.cwiseAbs().maxCoeff());
  const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues();
  return {e.minCoeff(), e.maxCoeff()};
}

}  // namespace

TEST_CASE("lumped inertia of a meshless body: masses the weights' row sums, inertias positive semidefinite",
          "[model][meshless]") {
  Model model = small_meshless_box().model;
  // The moving least squares weights of this box are negative at some samples: the case the
  // lumping must survive.
  REQUIRE(*std::min_element(model.neighbours.weights.begin(), model.neighbours.weights.end()) < -1e-3);
  compute_frame_inertia(model);
  const NeighbourTable& nb = model.neighbours;
  std::vector<double> row_sums(model.frame_count(), 0.0);
  for (int s = 0; s < model.sample_count(); ++s)
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p)
      row_sums[nb.frames[p]] += nb.weights[p] * model.materials[model.samples.materials[s]].density * model.samples.volumes[s];
  double total = 0;
  for (int i = 0; i < model.frame_count(); ++i) {
    INFO("frame " << i);
    REQUIRE(row_sums[i] > 0);
    REQUIRE(model.frame_masses[i] == Approx(row_sums[i]).epsilon(1e-12));
    total += model.frame_masses[i];
    const auto [lowest, highest] = inertia_range(model, i);
    // A sum of point-mass inertias m (|l|^2 I - l l^T) with m >= 0: eigenvalues >= 0 up to the
    // round-off of the sum (a few ulps of the largest).
    REQUIRE(lowest >= -1e-14 * highest);
  }
  // Partition of unity: each sample's mass is shared out whole.
  REQUIRE(total == Approx(sample_mass_sum(model)).epsilon(1e-12));
}

TEST_CASE("lumped inertia with non-negative weights: the sample masses in the weights' shares",
          "[model]") {
  // Trilinear hexahedra: weights in [0, 1] that sum to one, so the shares are the weights.
  Model model = small_box_model(CellType::hexahedron);
  const NeighbourTable& nb = model.neighbours;
  REQUIRE(*std::min_element(nb.weights.begin(), nb.weights.end()) >= 0);
  compute_frame_inertia(model);
  std::vector<double> masses(model.frame_count(), 0.0), inertias(9 * model.frame_count(), 0.0);
  for (int s = 0; s < model.sample_count(); ++s) {
    const double m_s = model.materials[model.samples.materials[s]].density * model.samples.volumes[s];
    for (int p = nb.offsets[s]; p < nb.offsets[s + 1]; ++p) {
      const int i = nb.frames[p];
      const double m = nb.weights[p] * m_s;
      const double* l = &nb.rest_offsets[3 * p];
      const double l2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
      masses[i] += m;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) inertias[9 * i + 3 * r + c] += m * ((r == c ? l2 : 0.0) - l[r] * l[c]);
    }
  }
  for (int i = 0; i < model.frame_count(); ++i) {
    REQUIRE(model.frame_masses[i] == Approx(masses[i]).epsilon(1e-12));
    for (int k = 0; k < 9; ++k)
      REQUIRE(model.frame_inertias[9 * i + k] == Approx(inertias[9 * i + k]).margin(1e-12 * masses[i] * 0.01));
  }
}
