// Finite-difference checks of the total potentials Newton minimises: gravity acting through
// eq. (3) (with its rotational Hessian blocks) and the backward-Euler inertia and damping terms.
#include "integrate/step_potential.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <vector>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("static potential: gradient and Hessian with gravity and point forces", "[integrate][fd]") {
  Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk);
  ExternalLoads loads;
  loads.gravity = Vec3{0.5, -9.81, 2.0};
  loads.point_forces.push_back({3, Vec3{1.0, 2.0, -3.0}});
  StepPotential potential(model, loads);
  potential.set_static();
  const State state = random_state(model, 17, 0.01, 0.8, 2.0);
  std::vector<double> g;
  potential.gradient(state, g);
  const Energy phi = [&](const State& s) { return potential.value(s); };
  const double scale = norm(g);
  for (int k = 0; k < model.dof_count(); ++k) {
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = 1.0;
    REQUIRE(std::abs(directional_derivative(model, phi, state, e) - g[k]) <= 1e-6 * scale);
  }
  potential.prepare_hessian(state);
  const LinearSystem sys = potential.system();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<double> d(model.dof_count()), hd(model.dof_count());
  for (double& v : d) v = 0.1 * u(rng);
  sys.apply(d.data(), hd.data());
  for (int k = 0; k < model.dof_count(); ++k) {
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = 0.1;
    const double fd = mixed_second_derivative(model, phi, state, d, e);
    REQUIRE(std::abs(fd - 0.1 * hd[k]) <= 1e-5 * norm(hd) * 0.1);
  }
}

TEST_CASE("backward-Euler potential: exact gradient of inertia and Rayleigh damping", "[integrate][fd]") {
  // StVK: the random trial state below may invert elements, where neo-Hookean is +inf.
  Model model = small_box_model(CellType::tetrahedron, MaterialLaw::stvk);
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  StepPotential potential(model, loads);
  State start = random_state(model, 5, 0.002, 0.3);
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double& v : start.velocities) v = 0.5 * u(rng);
  potential.set_dynamic(start, 0.01, 0.7, 0.002);
  // A trial state a finite step away, so the rotational increments phi are not small.
  const State state = [&] {
    State s = start;
    std::vector<double> d(model.dof_count());
    for (double& v : d) v = 0.4 * u(rng);
    for (int i = 0; i < model.frame_count(); ++i)
      for (int k = 0; k < 3; ++k) d[6 * i + k] *= 0.005;
    retract(model, s, d.data());
    return s;
  }();
  std::vector<double> g;
  potential.gradient(state, g);
  const Energy phi = [&](const State& s) { return potential.value(s); };
  const double scale = norm(g);
  for (int k = 0; k < model.dof_count(); ++k) {
    std::vector<double> e(model.dof_count(), 0.0);
    e[k] = 1.0;
    REQUIRE(std::abs(directional_derivative(model, phi, state, e) - g[k]) <= 1e-6 * scale);
  }
  // At the start state (Delta = 0) the Hessian's J_l ~ I approximation drops only the term
  // 1/2 [d]x I (-h w) / h^2, which is skew and vanishes in d^T H d: the quadratic form is exact
  // there and the mixed second difference (relative error ~ sqrt(eps), see the harness) must
  // match to 1e-5.
  potential.prepare_hessian(start);
  std::vector<double> d(model.dof_count()), hd(model.dof_count());
  for (double& v : d) v = 0.01 * u(rng);
  potential.system().apply(d.data(), hd.data());
  const double fd = mixed_second_derivative(model, phi, start, d, d);
  REQUIRE(fd == Approx(dot(d, hd)).epsilon(1e-5));
}

TEST_CASE("stiffness-proportional damping makes its start-of-step tangent for damping", "[integrate][backend]") {
  // The factory learns each elasticity's use, so a reduced-precision backend can keep damping's
  // K(q_n) dq, a term of the gradient, in double (mechanics/volumetric_elasticity.hpp). Each is
  // made at its first use: a run whose steps a backend solves makes neither.
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk);
  std::vector<ElasticityUse> made;
  const ElasticityFactory recording = [&made](const Model& m, int threads, ElasticityUse use) {
    made.push_back(use);
    return make_cpu_elasticity(m, threads);
  };
  const ExternalLoads loads;  // outlives the potential, which keeps a reference
  StepPotential potential(model, loads, 1, recording);
  CHECK(made.empty());
  const State start = rest_state(model);
  std::vector<double> g;
  potential.set_dynamic(start, 0.01, 0.5, 0.0);  // no stiffness damping: no second elasticity
  potential.gradient(start, g);
  CHECK(made == std::vector<ElasticityUse>{ElasticityUse::step});
  potential.set_dynamic(start, 0.01, 0.5, 0.002);
  CHECK(made.size() == 1);  // not before its first use
  potential.gradient(start, g);
  potential.set_dynamic(start, 0.01, 0.5, 0.002);  // made once, prepared at each start
  potential.gradient(start, g);
  CHECK(made == std::vector<ElasticityUse>{ElasticityUse::step, ElasticityUse::damping});
}
