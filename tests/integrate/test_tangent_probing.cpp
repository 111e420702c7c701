// The step tangent recovered from its assembled blocks and the rigid bodies' products
// (integrate/tangent_probing.hpp) equals the assembled one: every coupling between two unknowns
// that are not bodies lies in the block pattern, and the bodies' rows and columns come from their
// products whatever the blocks that involve a body hold.
#include "integrate/step_potential.hpp"
#include "integrate/tangent_probing.hpp"
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

bool is_body(const TangentProbing& t, int f) { return std::binary_search(t.bodies.begin(), t.bodies.end(), f); }

// The assembled blocks of t from the step tangent H (6N x 6N): H's blocks (a, b) with b <= a
// between frames that are not bodies. A block with a body holds what the device's assembly leaves
// out of H there (the terms through the body's carried frames), so here arbitrary values
// (symmetric on the diagonal, as H's are): the rule must subtract from the products exactly what
// it adds. The blocks with b > a, which hold no values, are NaN, so that a rule reading them fails.
std::vector<double> assembled_blocks(const TangentProbing& t, const Eigen::MatrixXd& H) {
  std::vector<double> blocks(36 * t.block_frames.size(), std::numeric_limits<double>::quiet_NaN());
  for (int a = 0; a < t.frames; ++a)
    for (int p = t.block_offsets[static_cast<size_t>(a)]; p < t.block_offsets[static_cast<size_t>(a) + 1]; ++p) {
      const int b = t.block_frames[static_cast<size_t>(p)];
      if (b > a) continue;
      const bool body = is_body(t, a) || is_body(t, b);
      for (int r = 0; r < 6; ++r)
        for (int c = 0; c < 6; ++c)
          blocks[36 * static_cast<size_t>(p) + 6 * static_cast<size_t>(r) + static_cast<size_t>(c)] =
              body ? std::sin(1.0 + p + 7.0 * std::min(r, c) + std::max(r, c)) : H(6 * a + r, 6 * b + c);
    }
  return blocks;
}

// H recovered by the per-entry rules of tangent_probing.hpp from the assembled blocks and the
// products of `system`, dense, with identity rows and columns at fixed DOFs.
Eigen::MatrixXd probe(const TangentProbing& t, const std::vector<double>& blocks, const LinearSystem& system) {
  const int n = system.size;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
  std::vector<double> e(static_cast<size_t>(n)), out(static_cast<size_t>(n));
  for (size_t c = 0; c < t.bodies.size(); ++c)
    for (int k = 0; k < 6; ++k) {
      const int body = t.bodies[c];
      for (int i = 0; i < n; ++i) e[static_cast<size_t>(i)] = probe_entry(system.fixed, body, k, i);
      system.apply(e.data(), out.data());
      for (int i = 0; i < n; ++i) {
        const long long col = probe_column(system.fixed, body, k, i);
        if (col < 0) continue;
        const double v = probe_value(out[static_cast<size_t>(i)], system.fixed, &t.body_blocks[c * static_cast<size_t>(t.frames)],
                                     blocks.data(), body, k, i);
        A(i, col) = v;
        A(col, i) = v;
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

void check_recovery(const Model& model, int expect_bodies) {
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  StepPotential potential(model, loads);
  State start = random_state(model, 3, 0.002, 0.2);
  potential.set_dynamic(start, 0.01, 0.5, 0.0);
  State state = random_state(model, 11, 0.004, 0.4);
  RigidMapping(model).sync(state);
  potential.prepare_hessian(state);
  const LinearSystem system = potential.system();
  const TangentProbing t = tangent_probing(model);
  REQUIRE(static_cast<int>(t.bodies.size()) == expect_bodies);
  REQUIRE(t.block_offsets.size() == static_cast<size_t>(model.frame_count()) + 1);
  // Every unknown has its diagonal block, and every two unknowns of a sample share a block.
  for (int f = 0; f < model.frame_count(); ++f) {
    const bool mapped = !model.rigid_parents.empty() && model.rigid_parents[static_cast<size_t>(f)] >= 0;
    REQUIRE((t.diagonal_blocks[static_cast<size_t>(f)] >= 0) == !mapped);
    if (!mapped) REQUIRE(t.diagonal_blocks[static_cast<size_t>(f)] == assembled_block(t.block_offsets.data(), t.block_frames.data(), f, f));
  }
  const auto& nb = model.neighbours;
  for (int s = 0; s < model.sample_count(); ++s)
    for (int p = nb.offsets[static_cast<size_t>(s)]; p < nb.offsets[static_cast<size_t>(s) + 1]; ++p)
      for (int q = nb.offsets[static_cast<size_t>(s)]; q < nb.offsets[static_cast<size_t>(s) + 1]; ++q) {
        const int a = nb.frames[static_cast<size_t>(p)], b = nb.frames[static_cast<size_t>(q)];
        const bool mapped = !model.rigid_parents.empty() && (model.rigid_parents[static_cast<size_t>(a)] >= 0 ||
                                                             model.rigid_parents[static_cast<size_t>(b)] >= 0);
        CAPTURE(s, a, b);
        REQUIRE((assembled_block(t.block_offsets.data(), t.block_frames.data(), a, b) >= 0) == !mapped);
      }

  const Eigen::MatrixXd H(system.assemble());
  const Eigen::MatrixXd A = probe(t, assembled_blocks(t, H), system);
  const int n = system.size;
  // A recovered entry is H's entry, or a product's entry less a block value plus the same value:
  // they agree to rounding of the largest entries (1e-12 of max |H|, and of the blocks' values of
  // at most 1 with a body).
  const double tol = 1e-12 * std::max(1.0, H.cwiseAbs().maxCoeff());
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const bool fixed = system.fixed[i] || system.fixed[j];
      const double expected = fixed ? (i == j ? 1.0 : 0.0) : H(i, j);
      CAPTURE(i, j);
      REQUIRE(std::abs(A(i, j) - expected) <= tol);
    }
}

// The coupled block with a second shell on its side face y = 0, from its bottom edge (frames
// carried by the plate) to its top edge: triangles with frames on the body and frames that are not.
Model side_wall_model() {
  const Model block = small_box_model(CellType::hexahedron);
  SurfaceMesh side = rectangle_surface(0.2, 0.1, 2, 2);
  for (int k = 0; k < side.vertex_count(); ++k) {
    side.vertices[3 * k + 2] = 0.5 * side.vertices[3 * k + 1];
    side.vertices[3 * k + 1] = 0.0;
  }
  ModelBuilder builder;
  const int tissue = builder.add_tissue("tissue", block, SurfaceMesh{});
  const int wall = builder.add_shell("wall", side, ShellProperties{0.004, 5.0e4, 0.35, 1000.0});
  const int bone = builder.add_rigid("bone", box_surface({0, 0, -0.02}, {0.2, 0.1, 0}), 1000.0);
  REQUIRE(builder.share(tissue, wall, 1e-6) == 6);
  REQUIRE(builder.attach(tissue, bone, 1e-6) > 0);
  REQUIRE(builder.attach(wall, bone, 1e-6) > 0);
  Model model = builder.build();
  // The wall's bottom row is carried by the plate, the rest of it is not.
  int carried = 0;
  for (int f : model.shells.at(0).triangles) carried += model.rigid_parents[static_cast<size_t>(f)] >= 0;
  REQUIRE(carried > 0);
  REQUIRE(carried < static_cast<int>(model.shells.at(0).triangles.size()));
  return model;
}

}  // namespace

TEST_CASE("tangent probing recovers the step tangent of tissue, shell and rigid body", "[integrate]") {
  SECTION("a shell on the tissue, the tissue on a plate") { check_recovery(coupled_model(CellType::hexahedron), 1); }
  SECTION("a shell from the plate's frames to the tissue's") { check_recovery(side_wall_model(), 1); }
  SECTION("shells and a rigid body without samples") { check_recovery(shells_and_rigid_model(), 0); }
}

TEST_CASE("tangent probing recovers the tangent of tetrahedra with a fixed face", "[integrate]") {
  const Model model = small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 3, 2, 2);
  // A tissue alone: every coupling lies in the assembled blocks, and no product is needed.
  REQUIRE(tangent_probing(model).bodies.empty());
  check_recovery(model, 0);
}
