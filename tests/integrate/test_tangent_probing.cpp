// The step tangent recovered from its assembled elastic blocks and coloured products
// (integrate/tangent_probing.hpp) equals the assembled one: every coupling outside the blocks is in
// the colouring's graph, no two columns of a colour meet there in a row that is not a hub's, and
// hub rows are their columns transposed.
#include "integrate/step_potential.hpp"
#include "integrate/tangent_probing.hpp"
#include "mechanics/assembled_tangent.hpp"
#include "mechanics/elasticity.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>

using namespace fascia;
using namespace fascia::test;

namespace {

// The assembled blocks of t from the elastic tangent K (6N x 6N) at the state: K's blocks (a, b)
// with b <= a (their rotational geometric part included: the rest of H is read from the products
// whatever the blocks hold on the diagonal); the blocks with b > a, which hold no values, are NaN,
// so that a rule reading them fails.
std::vector<double> assembled_blocks(const TangentProbing& t, const Eigen::MatrixXd& K) {
  std::vector<double> blocks(36 * t.block_frames.size(), std::numeric_limits<double>::quiet_NaN());
  for (int a = 0; a < t.frames; ++a)
    for (int p = t.block_offsets[static_cast<size_t>(a)]; p < t.block_offsets[static_cast<size_t>(a) + 1]; ++p) {
      const int b = t.block_frames[static_cast<size_t>(p)];
      if (b > a) continue;
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c)
          blocks[36 * static_cast<size_t>(p) + 6 * static_cast<size_t>(r) + static_cast<size_t>(c)] =
              K(6 * a + r, 6 * b + c);
    }
  return blocks;
}

// H recovered by the per-entry rules of tangent_probing.hpp from the assembled blocks and the
// products of `system`, dense, with identity rows and columns at fixed DOFs.
Eigen::MatrixXd probe(const TangentProbing& t, const std::vector<double>& blocks, const LinearSystem& system) {
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
        const double v = probe_value(out[static_cast<size_t>(i)], system.fixed, t.colour_block_offsets.data(),
                                     t.colour_block_frames.data(), t.colour_blocks.data(), blocks.data(), t.colours, c,
                                     k, i);
        A(i, col) = v;
        if (mirror) A(col, i) = v;
      }
    }
  // Each block (a, b) with b < a at its place and transposed, the diagonal blocks once.
  for (int a = 0; a < t.frames; ++a)
    for (int p = t.block_offsets[static_cast<size_t>(a)]; p < t.block_offsets[static_cast<size_t>(a) + 1]; ++p) {
      const int b = t.block_frames[static_cast<size_t>(p)];
      if (b > a) continue;
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c) {
          const int i = 6 * a + r, j = 6 * b + c;
          if (system.fixed[i] || system.fixed[j]) continue;
          const double v = blocks[36 * static_cast<size_t>(p) + 6 * static_cast<size_t>(r) + static_cast<size_t>(c)];
          A(i, j) += v;
          if (a != b) A(j, i) += v;
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
  // Every sample's unknown frames are coupled in the assembled blocks, and the rest's colouring is
  // no larger than the whole tangent's would be.
  REQUIRE(t.block_offsets.size() == static_cast<size_t>(model.frame_count()) + 1);
  for (int s = 0; s < model.sample_count(); ++s)
    for (int p = model.neighbours.offsets[static_cast<size_t>(s)]; p < model.neighbours.offsets[static_cast<size_t>(s) + 1]; ++p)
      for (int q = model.neighbours.offsets[static_cast<size_t>(s)]; q < model.neighbours.offsets[static_cast<size_t>(s) + 1]; ++q) {
        const int a = model.neighbours.frames[static_cast<size_t>(p)], b = model.neighbours.frames[static_cast<size_t>(q)];
        const bool mapped = !model.rigid_parents.empty() && (model.rigid_parents[static_cast<size_t>(a)] >= 0 ||
                                                             model.rigid_parents[static_cast<size_t>(b)] >= 0);
        CAPTURE(s, a, b);
        REQUIRE((assembled_block(t.block_offsets.data(), t.block_frames.data(), a, b) >= 0) == !mapped);
      }

  Elasticity elasticity(model, 1);
  elasticity.prepare(state);
  const std::vector<double> blocks = assembled_blocks(t, Eigen::MatrixXd(assemble_tangent(elasticity)));
  const Eigen::MatrixXd A = probe(t, blocks, system);
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
  // A tissue alone couples its frames through its samples only: all in the assembled blocks, so
  // one colour (6 products) reads the diagonal frame terms.
  REQUIRE(tangent_probing(model).colours == 1);
  check_recovery(model, 0, 0);
}
