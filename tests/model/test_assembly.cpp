// Multi-object models (model/assembly.hpp) and rigid-body mass properties.
#include "core/rotation.hpp"
#include "mechanics/elasticity.hpp"
#include "mechanics/shell.hpp"
#include "model/assembly.hpp"
#include "model/mass_properties.hpp"
#include "support/fixtures.hpp"
#include "support/shell_fixtures.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("mass properties of a closed surface match the analytic box", "[model][rigid]") {
  // A 0.3 x 0.2 x 0.1 m box, rotated by Q and translated: m = rho V, I_c = Q diag(...) Q^T with
  // diag = m/12 (b^2 + c^2, a^2 + c^2, a^2 + b^2). Exact for a polyhedron: round-off margins.
  const double a = 0.3, b = 0.2, c = 0.1, rho = 1900;
  SurfaceMesh box = box_surface({-a / 2, -b / 2, -c / 2}, {a / 2, b / 2, c / 2});
  const Mat3 Q = rotation_matrix(quat_exp(Vec3{0.4, -0.9, 0.3}));
  const Vec3 centre{1.5, -0.7, 2.0};
  for (int k = 0; k < box.vertex_count(); ++k) store3(&box.vertices[3 * k], Q * load3(&box.vertices[3 * k]) + centre);
  const MassProperties p = mass_properties(box, rho);
  const double m = rho * a * b * c;
  REQUIRE(p.volume == Approx(a * b * c).epsilon(1e-12));
  REQUIRE(p.mass == Approx(m).epsilon(1e-12));
  REQUIRE(norm(p.centre - centre) < 1e-12);
  Mat3 D = zero3();
  D.m[0][0] = m / 12 * (b * b + c * c), D.m[1][1] = m / 12 * (a * a + c * c), D.m[2][2] = m / 12 * (a * a + b * b);
  const Mat3 expected = Q * D * transpose(Q);
  for (int r = 0; r < 3; ++r)
    for (int col = 0; col < 3; ++col) REQUIRE(p.inertia.m[r][col] == Approx(expected.m[r][col]).margin(1e-12 * m * a * a));
}

TEST_CASE("a shared frame receives the sum of both objects' forces", "[model][coupling]") {
  // A hexahedral tissue block 0.2 x 0.1 x 0.05 m and a shell on its top face with vertices on
  // the block's top frames: sharing merges them. At one deformed state, the coupled model's
  // elastic + shell gradient at each merged frame must equal the block's gradient there plus
  // the shell's, each computed on its own single-object model.
  const Model block = small_box_model(CellType::hexahedron);
  SurfaceMesh top = rectangle_surface(0.2, 0.1, 2, 2);
  for (int k = 0; k < top.vertex_count(); ++k) top.vertices[3 * k + 2] = 0.05;
  const ShellProperties wall{0.004, 5.0e4, 0.35, 1000.0};
  ModelBuilder builder;
  const int tissue = builder.add_tissue("tissue", block, SurfaceMesh{});
  const int shell = builder.add_shell("wall", top, wall);
  REQUIRE(builder.share(tissue, shell, 1e-6) == 9);
  const Model coupled = builder.build();
  REQUIRE(coupled.frame_count() == block.frame_count());  // 18 + 9 - 9 merged
  const Model wall_only = shell_model(top, wall);

  // The same smooth motion field evaluated at each model's frames.
  auto state_of = [](const Model& m) {
    State s = rest_state(m);
    for (int i = 0; i < m.frame_count(); ++i) {
      const Vec3 x = load3(&m.frame_rest_positions[3 * i]);
      store3(&s.positions[3 * i], x + Vec3{0.01 * x.y, 0.02 * x.x * x.x, 0.3 * x.x * x.y});
      store_quat(&s.orientations[4 * i], quat_exp(Vec3{2 * x.y, -3 * x.x, x.z}));
    }
    return s;
  };
  auto frame_at = [](const Model& m, const Vec3& x) {
    for (int i = 0; i < m.frame_count(); ++i)
      if (norm(load3(&m.frame_rest_positions[3 * i]) - x) < 1e-12) return i;
    return -1;
  };
  std::vector<double> g_coupled(coupled.dof_count(), 0.0), g_block(block.dof_count(), 0.0),
      g_wall(wall_only.dof_count(), 0.0);
  Elasticity(coupled).gradient(state_of(coupled), g_coupled.data());
  ShellForceField(coupled, coupled.shells.front()).add_gradient(state_of(coupled), g_coupled.data());
  Elasticity(block).gradient(state_of(block), g_block.data());
  ShellForceField(wall_only, wall_only.shells.front()).add_gradient(state_of(wall_only), g_wall.data());
  int checked = 0;
  double scale = 0;
  for (double v : g_block) scale = std::max(scale, std::abs(v));
  for (int i = 0; i < coupled.frame_count(); ++i) {
    const Vec3 x = load3(&coupled.frame_rest_positions[3 * i]);
    const int ib = frame_at(block, x), iw = frame_at(wall_only, x);
    REQUIRE(ib >= 0);
    for (int k = 0; k < 6; ++k) {
      const double expected = g_block[6 * ib + k] + (iw >= 0 ? g_wall[6 * iw + k] : 0.0);
      REQUIRE(g_coupled[6 * i + k] == Approx(expected).margin(1e-12 * scale));
    }
    if (iw >= 0) {
      ++checked;
      REQUIRE(std::abs(g_wall[6 * iw + 2]) > 0);  // the shell really contributes there
    }
  }
  REQUIRE(checked == 9);
  // Masses add too: the block's samples and the shell's lumped masses.
  REQUIRE(coupled.total_mass() == Approx(block.total_mass() + wall.density * wall.thickness * 0.2 * 0.1).epsilon(1e-12));
}
