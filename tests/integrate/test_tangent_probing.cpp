// The step tangent recovered from coloured products (integrate/tangent_probing.hpp) equals the
// assembled one: every coupling of the model is in the colouring's graph, no two columns of a
// colour meet in a row that is not a hub's, and hub rows are their columns transposed.
#include "integrate/step_potential.hpp"
#include "integrate/tangent_probing.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

using namespace fascia;
using namespace fascia::test;

namespace {

// H recovered by the per-entry rule of tangent_probing.hpp from the products of `system`, dense,
// with identity rows and columns at fixed DOFs.
Eigen::MatrixXd probe(const TangentProbing& t, const LinearSystem& system) {
  const int n = system.size;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  std::vector<double> e(static_cast<size_t>(n)), out(static_cast<size_t>(n));
  for (int c = 0; c < t.colours; ++c)
    for (int k = 0; k < 6; ++k) {
      for (int i = 0; i < n; ++i) e[static_cast<size_t>(i)] = probe_entry(t.colour.data(), system.fixed, c, k, i);
      system.apply(e.data(), out.data());
      for (int i = 0; i < n; ++i) {
        bool mirror = false;
        const long long col = probe_column(&t.owner[static_cast<size_t>(c) * static_cast<size_t>(t.frames)],
                                           t.hub_frame[static_cast<size_t>(c)], system.fixed, k, i, mirror);
        if (col < 0) continue;
        A(i, col) = out[static_cast<size_t>(i)];
        if (mirror) A(col, i) = out[static_cast<size_t>(i)];
      }
    }
  for (int i = 0; i < n; ++i)
    if (system.fixed[i]) A(i, i) = 1;
  return A;
}

void check_recovery(const Model& model, int hub_degree, int expect_hubs_at_least) {
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  StepPotential potential(model, loads);
  State start = random_state(model, 3, 0.002, 0.2);
  potential.set_dynamic(start, 0.01, 0.5, 0.0);
  const State state = random_state(model, 11, 0.004, 0.4);
  potential.prepare_hessian(state);
  const LinearSystem system = potential.system();
  const TangentProbing t = tangent_probing(model, hub_degree);
  const int hubs = static_cast<int>(std::count_if(t.hub_frame.begin(), t.hub_frame.end(), [](int h) { return h >= 0; }));
  REQUIRE(hubs >= expect_hubs_at_least);
  CAPTURE(t.colours, hubs);
  REQUIRE(t.colours < model.frame_count());  // probing costs fewer products than unit vectors

  const Eigen::MatrixXd A = probe(t, system);
  const Eigen::MatrixXd H(system.assemble());
  const int n = system.size;
  // Each recovered entry is one product's entry, and the assembled matrix sums the same terms in
  // another order: they agree to rounding of the largest entries (1e-12 of max |H|).
  const double tol = 1e-12 * H.cwiseAbs().maxCoeff();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const bool fixed = system.fixed[i] || system.fixed[j];
      const bool hub_row = t.hub_frame[static_cast<size_t>(std::max(0, t.colour[static_cast<size_t>(i / 6)]))] == i / 6;
      const double expected = fixed ? (i == j ? 1.0 : 0.0) : (hub_row ? H(j, i) : H(i, j));
      CAPTURE(i, j);
      REQUIRE(std::abs(A(i, j) - expected) <= tol);
    }
}

}  // namespace

TEST_CASE("tangent probing recovers the assembled step tangent of tissue, shell and rigid body", "[integrate]") {
  const Model model = coupled_model(CellType::hexahedron);
  SECTION("hubs by the median rule") { check_recovery(model, 0, 0); }
  // A hub degree of 8 makes the rigid plate's frame and the block's well-connected frames hubs.
  SECTION("hubs") { check_recovery(model, 8, 2); }
}

TEST_CASE("tangent probing recovers the tangent of tetrahedra with a fixed face", "[integrate]") {
  const Model model = small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 3, 2, 2);
  check_recovery(model, 0, 0);
}
