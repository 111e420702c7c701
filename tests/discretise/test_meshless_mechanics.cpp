// Forces, tangents and invariance of the frame mechanics with meshless shape functions (the
// mechanics tests of tests/mechanics, run on meshless models).
#include "core/rotation.hpp"
#include "mechanics/elasticity.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"
#include "support/meshless_fixtures.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("meshless: forces are minus the gradient of the energy", "[discretise][meshless][fd]") {
  const MaterialLaw law = GENERATE(MaterialLaw::stvk, MaterialLaw::neo_hookean);
  const Model model = small_meshless_box(law).model;
  // Displacements of 2 mm on 40 mm frame spacing: strains ~ 0.05 to 0.1, no inversion.
  const State state = random_state(model, 7, 0.002, 0.3, 2.0);
  Elasticity elasticity(model, 1);  // tiny model: one thread avoids OpenMP overhead
  std::vector<double> g(model.dof_count());
  const double w = elasticity.gradient(state, g.data());
  REQUIRE(std::isfinite(w));
  REQUIRE(w > 0);
  const Energy energy = [&](const State& s) { return elasticity.energy(s); };
  const double scale = norm(g);
  // Tolerance and step: see finite_difference.hpp.
  for (int k = 0; k < model.dof_count(); ++k) {
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = 1.0;
    const double fd = directional_derivative(model, energy, state, e);
    INFO("dof " << k << " fd " << fd << " analytic " << g[k]);
    REQUIRE(std::abs(fd - g[k]) <= 1e-6 * scale);
  }
}

TEST_CASE("meshless: tangent product is the Hessian of the energy and symmetric", "[discretise][meshless][fd]") {
  const Model model = small_meshless_box(MaterialLaw::stvk).model;
  const State state = random_state(model, 11, 0.002, 0.5, 2.5);
  Elasticity elasticity(model, 1);  // tiny model: one thread avoids OpenMP overhead
  elasticity.prepare(state);
  const Energy energy = [&](const State& s) { return elasticity.energy(s); };
  const std::vector<double> d = random_direction(model, 1, 0.01), e2 = random_direction(model, 2, 0.01);
  std::vector<double> kd(model.dof_count()), ke(model.dof_count());
  elasticity.apply_tangent(d.data(), kd.data());
  elasticity.apply_tangent(e2.data(), ke.data());
  REQUIRE(std::abs(dot(e2, kd) - dot(d, ke)) <= 1e-12 * norm(kd) * norm(e2));
  const double scale = norm(kd);
  for (int k = 0; k < model.dof_count(); ++k) {
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = k % 6 < 3 ? 0.01 : 1.0;  // same length scale as d
    const double fd = mixed_second_derivative(model, energy, state, d, e);
    INFO("dof " << k << " fd " << fd << " analytic " << kd[k] * e[k]);
    REQUIRE(std::abs(fd - kd[k] * e[k]) <= 1e-5 * scale);
  }
}

TEST_CASE("meshless: rigid motions give zero energy and force; forces rotate with the body",
          "[discretise][meshless][invariance]") {
  const Model model = small_meshless_box(MaterialLaw::stvk).model;
  const Vec3 rot{1.1, -0.4, 2.0}, t{0.3, 0.1, -0.7};
  const Quat q = quat_exp(rot);
  const Mat3 Q = rotation_matrix(q);
  const auto moved = [&](const State& s) {
    State m = s;
    for (int i = 0; i < s.frame_count(); ++i) {
      store3(&m.positions[3 * i], Q * load3(&s.positions[3 * i]) + t);
      store_quat(&m.orientations[4 * i], normalized(q * load_quat(&s.orientations[4 * i])));
    }
    return m;
  };
  Elasticity elasticity(model, 1);  // tiny model: one thread avoids OpenMP overhead
  std::vector<double> g(model.dof_count()), gm(model.dof_count());
  // Energy scale E * volume = 1e4 * 1e-3 = 10 J, force scale E * area ~ 1e2 N; round-off only.
  REQUIRE(std::abs(elasticity.gradient(moved(rest_state(model)), g.data())) <= 1e-12);
  for (double x : g) REQUIRE(std::abs(x) <= 1e-9);
  const State state = random_state(model, 21, 0.002, 0.4);
  const double w = elasticity.gradient(state, g.data());
  REQUIRE(elasticity.gradient(moved(state), gm.data()) == Approx(w).epsilon(1e-12));
  for (int i = 0; i < model.frame_count(); ++i) {
    REQUIRE(norm(Q * load3(&g[6 * i]) - load3(&gm[6 * i])) <= 1e-10 * norm(g));
    REQUIRE(norm(Q * load3(&g[6 * i + 3]) - load3(&gm[6 * i + 3])) <= 1e-10 * norm(g));
  }
}
