// Whole steps: the StVK uniaxial analytic case solved statically, momentum conservation of a
// free body under backward Euler, unit quaternions over long runs, and failures reported.
#include "core/rotation.hpp"
#include "discretise/mesh_based.hpp"
#include "discretise/probe.hpp"
#include "integrate/simulation.hpp"
#include "integrate/step_potential.hpp"
#include "support/coupling_fixtures.hpp"
#include "support/fixtures.hpp"
#include "support/hgo_uniaxial.hpp"
#include "support/meshless_fixtures.hpp"
#include "support/minimiser_bound.hpp"
#include "support/resume_check.hpp"

#include <catch2/catch.hpp>

#include <cstring>

using namespace fascia;

namespace {

// A bar [0, L] x [0, a]^2 on symmetry planes (x = 0 fixed in x, y = 0 in y, z = 0 in z) pulled by
// a uniform traction of total force f on x = L, applied as forces on material points of the
// end face (eq. 3), which also load the frames' rotations with the traction's moment.
struct Bar {
  Model model;
  ExternalLoads loads;
  double lambda = 1, lateral = 1;  // analytic stretches
};

// material: the bar's law (StVK, E = 4e4 Pa, nu = 0.3, unless given); the analytic stretches
// below are StVK's (the hgo test computes its own).
Bar make_bar(CellType type, bool locked, const Material* material = nullptr) {
  const double L = 2.0, a = 0.5, E = 4e4, nu = 0.3, f = 2000.0;
  const VolumeMesh mesh = type == CellType::hexahedron ? box_hex_mesh({0, 0, 0}, {L, a, a}, 4, 1, 1)
                                                       : box_tet_mesh({0, 0, 0}, {L, a, a}, 4, 1, 1);
  Bar bar;
  bar.model = build_mesh_model(mesh, material ? *material : make_material(MaterialLaw::stvk, E, nu, 1));
  if (locked) lock_rotations(bar.model);
  // Mirror symmetry on the plane x_k = 0 fixes the normal translation and, for 6-DOF frames, the
  // rotations about the two in-plane axes.
  for (int i = 0; i < bar.model.frame_count(); ++i) {
    const double* x = &bar.model.frame_rest_positions[3 * i];
    for (int k = 0; k < 3; ++k)
      if (x[k] < 1e-12) {
        bar.model.fixed_dofs[6 * i + k] = 1;
        bar.model.fixed_dofs[6 * i + 3 + (k + 1) % 3] = 1;
        bar.model.fixed_dofs[6 * i + 3 + (k + 2) % 3] = 1;
      }
  }
  // Uniform traction t = f / a^2 on x = L as material-point forces. The integrands are the face
  // weights (bilinear on hexahedron faces, linear on tetrahedron faces) times l = X - x_i, so
  // 3 x 3 Gauss points per hexahedron face and the 3 edge midpoints per triangle (degree 2) are
  // exact.
  auto add_point = [&](const Vec3& X, double dA) {
    const Probe probe = make_probe(mesh, X);
    bar.loads.material_point_forces.push_back(
        {probe.frames, probe.weights, probe.rest_offsets, Vec3{f / (a * a) * dA, 0, 0}});
  };
  const int k = mesh.nodes_per_cell();
  for (int c = 0; c < mesh.cell_count(); ++c) {
    std::vector<Vec3> face;
    for (int v = 0; v < k; ++v) {
      const Vec3 X = load3(&mesh.vertices[3 * mesh.cells[k * c + v]]);
      if (X.x > L - 1e-12) face.push_back(X);
    }
    if (k == 4 && face.size() == 3) {
      const double area = 0.5 * norm(cross(face[1] - face[0], face[2] - face[0]));
      for (int e = 0; e < 3; ++e) add_point(0.5 * (face[e] + face[(e + 1) % 3]), area / 3);
    } else if (k == 8 && face.size() == 4) {
      const double g3[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, w3[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
      for (int qy = 0; qy < 3; ++qy)
        for (int qz = 0; qz < 3; ++qz)
          add_point(Vec3{L, 0.5 * a * (1 + g3[qy]), 0.5 * a * (1 + g3[qz])}, 0.25 * a * a * w3[qy] * w3[qz]);
    }
  }
  // Analytic: P11 = lambda S11 = f / a^2 with S11 = E E11, E11 = (lambda^2 - 1) / 2, E22 = -nu E11.
  for (int it = 0; it < 50; ++it) {
    const double r = bar.lambda * E * 0.5 * (bar.lambda * bar.lambda - 1) - f / (a * a);
    bar.lambda -= r / (E * 0.5 * (3 * bar.lambda * bar.lambda - 1));
  }
  bar.lateral = std::sqrt(1 - nu * (bar.lambda * bar.lambda - 1));
  return bar;
}

// Solves bar's static equilibrium (Newton to 1e-11 of the load, direct solves) and requires every
// frame at diag(sx, sy, sz) X: a homogeneous deformation, which linear and trilinear elements
// reproduce exactly, so only round-off and the Newton tolerance separate them (1e-9 m).
void require_static_stretch(const Bar& bar, double sx, double sy, double sz) {
  SimulationSettings settings;
  settings.integrator = Integrator::static_equilibrium;
  settings.newton.tolerance = 1e-11;
  settings.newton.linear.method = LinearMethod::cholmod;
  Simulation sim(bar.model, bar.loads, settings);
  sim.step();
  for (int i = 0; i < bar.model.frame_count(); ++i) {
    const Vec3 X = load3(&bar.model.frame_rest_positions[3 * i]);
    const Vec3 x = load3(&sim.state().positions[3 * i]);
    CAPTURE(i);
    REQUIRE(x.x == Approx(sx * X.x).margin(1e-9));
    REQUIRE(x.y == Approx(sy * X.y).margin(1e-9));
    REQUIRE(x.z == Approx(sz * X.z).margin(1e-9));
  }
}

// The root of an increasing f on [lo, hi] by bisection, to the last bit.
template <class F>
double bisect(F f, double lo, double hi) {
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (f(mid) < 0 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

TEST_CASE("StVK bar under end tractions reaches the analytic uniaxial stretch", "[integrate][analytic]") {
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  const bool locked = GENERATE(true, false);
  INFO("tetrahedra " << (type == CellType::tetrahedron) << ", locked rotations " << locked);
  Bar bar = make_bar(type, locked);
  require_static_stretch(bar, bar.lambda, bar.lateral, bar.lateral);
  REQUIRE(bar.lambda > 1.05);  // a genuinely nonlinear stretch (P11 / E = 0.2)
}

TEST_CASE("hgo bar under end tractions reaches the closed-form stretch along and across its fibres",
          "[integrate][analytic][hgo]") {
  // The traction P11 = f / a^2 = 8000 Pa along x on the bar of make_bar, fibres along x or y (k1 =
  // 5e4 Pa, k2 = 5, no dispersion), ground substance E = 4e4 Pa, nu = 0.3. Homogeneous
  // F = diag(s, t2, t3); from hgo.hpp with the lateral faces free (tests/material/test_hgo.cpp):
  //   along:  mu (t^2 - 1) + lambda ln(s t^2) = 0,  P11 = mu (s - t^2 / s) + 2 g s,
  //           g = k1 (s^2 - 1) exp(k2 (s^2 - 1)^2);  t2 = t3 = t
  //   across: the fibres (along y) shorten and carry nothing: P11 = mu (s - t^2 / s) with the same
  //           lateral equation.
  // Each lateral t is a bisection root; s is found by bisection on P11(s) = f / a^2.
  const bool along = GENERATE(true, false);
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  INFO("fibres " << (along ? "along" : "across") << " the load, tetrahedra " << (type == CellType::tetrahedron));
  const Material m = make_hgo_material(4e4, 0.3, 1, Fibres{5e4, 5, 0, along ? Vec3{1, 0, 0} : Vec3{0, 1, 0}});
  Bar bar = make_bar(type, true, &m);
  const auto lateral = [&](double s) {
    return bisect([&](double t) { return m.mu * (t * t - 1) + m.lambda * std::log(s * t * t); }, 0.3, 1.0);
  };
  const auto p11 = [&](double s) {
    const double t = lateral(s), e = s * s - 1;
    return m.mu * (s - t * t / s) + (along ? 2 * m.fibres.k1 * e * std::exp(m.fibres.k2 * e * e) * s : 0.0);
  };
  const double s = bisect([&](double x) { return p11(x) - 2000.0 / 0.25; }, 1.0, 2.0), t = lateral(s);
  require_static_stretch(bar, s, t, t);
  // Fibres along the load stiffen it: a smaller stretch than across (the ground substance alone).
  if (along) REQUIRE(s < 1.1);
  else REQUIRE(s > 1.15);
}

TEST_CASE("uncoupled hgo bar with two fibre families reaches the closed-form stretches", "[integrate][analytic][hgo]") {
  // The traction P11 = 8000 Pa of make_bar along x; two fibre families at +-30 deg about x in the
  // x-y plane (k1 = 5e4 Pa, k2 = 5, dispersion 0.1), the uncoupled form with E = 4e4 Pa, nu = 0.45.
  // The homogeneous F = diag(s, t2, t3) is an equilibrium (P diagonal: the families' shear terms
  // cancel); its closed form is tests/support/hgo_uniaxial.hpp: t2, t3 from free lateral faces,
  // s by bisection on P11(s) = tau_1 / s = 8000 Pa.
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  INFO("tetrahedra " << (type == CellType::tetrahedron));
  const double gamma = 30 * 3.14159265358979323846 / 180;
  Fibres fibres{5e4, 5, 0.1, Vec3{1, 0, 0}};
  fibres.families = 2;
  fibres.angle = gamma;
  fibres.plane = Vec3{0, 1, 0};
  const Material m = make_hgo_material(4e4, 0.45, 1, fibres, HgoFormulation::uncoupled);
  Bar bar = make_bar(type, true, &m);
  double l[3];
  const auto p11 = [&](double s) {
    test::solve_lateral(m, gamma, 0, s, l);
    return test::principal_stresses(m, gamma, l).tau[0] / s;
  };
  p11(bisect([&](double x) { return p11(x) - 2000.0 / 0.25; }, 1.0, 2.0));
  require_static_stretch(bar, l[0], l[1], l[2]);
  // The families pull the bar in along y (in their plane) more than along z: t2 < t3.
  REQUIRE(l[1] < l[2]);
  REQUIRE(l[0] > 1.01);
}

TEST_CASE("with 6-DOF frames the analytic uniaxial state is an equilibrium", "[integrate][analytic]") {
  // The frame model contains the FEM fields (R = I), so the homogeneous state is an equilibrium
  // when the traction is applied consistently (with its moments about the frames).
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  Bar bar = make_bar(type, false);
  StepPotential potential(bar.model, bar.loads);
  State state = rest_state(bar.model);
  for (int i = 0; i < bar.model.frame_count(); ++i) {
    const Vec3 X = load3(&bar.model.frame_rest_positions[3 * i]);
    store3(&state.positions[3 * i], Vec3{bar.lambda * X.x, bar.lateral * X.y, bar.lateral * X.z});
  }
  std::vector<double> g;
  potential.gradient(state, g);
  // Sum of |terms| ~ f = 2000 N; round-off 1e-16 relative per term.
  REQUIRE(free_norm(bar.model, g) <= 1e-9 * 2000.0);
  std::fill(state.positions.begin(), state.positions.end(), 0.0);  // and a wrong state is not
  state.positions = bar.model.frame_rest_positions;
  potential.gradient(state, g);
  REQUIRE(free_norm(bar.model, g) > 1.0);
}

TEST_CASE("a free body conserves linear momentum under backward Euler without damping", "[integrate][momentum]") {
  const Model model = fascia::test::small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 3, 2, 2);
  SimulationSettings settings;
  settings.integrator = Integrator::backward_euler;
  settings.dt = 0.005;
  settings.newton.tolerance = 1e-12;
  settings.newton.linear.method = LinearMethod::cholmod;
  Simulation sim(model, ExternalLoads{}, settings);
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1, 1);
  for (double& v : sim.state().velocities) v = 0.3 * u(rng);  // deforming, spinning start
  auto momentum = [&] {
    Vec3 p{0, 0, 0};
    for (int i = 0; i < model.frame_count(); ++i) p += model.frame_masses[i] * load3(&sim.state().velocities[6 * i]);
    return p;
  };
  const Vec3 p0 = momentum();
  double speed = 0;
  for (int i = 0; i < model.frame_count(); ++i) speed += model.frame_masses[i] * norm(load3(&sim.state().velocities[6 * i]));
  for (int k = 0; k < 20; ++k) sim.step();
  // sum_i m_i dv_i = -h sum_i dW/dx_i = 0 exactly (translation invariance); the residual
  // tolerance 1e-12 bounds the error per step.
  REQUIRE(norm(momentum() - p0) <= 1e-9 * speed);
  for (int i = 0; i < model.frame_count(); ++i) {
    const Quat q = load_quat(&sim.state().orientations[4 * i]);
    REQUIRE(std::abs(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z - 1) <= 1e-15);
  }
}

TEST_CASE("a meshless body falling from rest takes small steps in one Newton iteration", "[integrate][meshless]") {
  // At h = 10 us the step's Hessian is M / h^2 plus a stiffness some 1e-4 of it: Newton's first
  // direction is the answer to about that ratio, and one iteration meets the tolerance, provided
  // M is positive definite (model/model.hpp: an inertia lumped with this box's negative moving
  // least squares weights would not be, and the shifted factorisation would leave Newton
  // crawling).
  const Model model = fascia::test::small_meshless_box().model;
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.integrator = Integrator::backward_euler;
  settings.dt = 1e-5;
  settings.newton.linear.method = LinearMethod::cholmod;
  Simulation sim(model, loads, settings);
  for (int k = 0; k < 3; ++k) {
    const StepReport r = sim.step();
    REQUIRE(r.converged);
    REQUIRE(r.newton_iterations <= 2);
  }
}

TEST_CASE("a beam under gravity settles with damping and keeps unit quaternions", "[integrate]") {
  Model model = fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 4, 1, 1);
  fix_frames(model, [](double x, double, double) { return x <= 1e-12; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.dt = 0.01;
  settings.rayleigh_mass = 5.0;
  settings.newton.linear.method = LinearMethod::pcg;
  Simulation sim(model, loads, settings);
  double previous = 1e300;
  for (int k = 0; k < 200; ++k) {
    const StepReport r = sim.step();
    REQUIRE(r.converged);
    const double total = r.elastic_energy + r.kinetic_energy + r.external_potential;
    if (k > 50) REQUIRE(total <= previous + 1e-9 * std::abs(previous));  // damped: energy decreases
    previous = total;
  }
  for (int i = 0; i < model.frame_count(); ++i) {
    const Quat q = load_quat(&sim.state().orientations[4 * i]);
    REQUIRE(std::abs(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z - 1) <= 1e-15);
  }
}

TEST_CASE("a solver failure is reported as SolverError and the state keeps the last step", "[integrate]") {
  Model model = fascia::test::small_box_model(CellType::tetrahedron, MaterialLaw::stvk);
  fix_frames(model, [](double x, double, double) { return x <= 1e-12; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81e6};  // absurd load: Newton cannot converge in 2 iterations
  SimulationSettings settings;
  settings.integrator = Integrator::backward_euler;
  settings.dt = 1.0;
  settings.newton.max_iterations = 2;
  Simulation sim(model, loads, settings);
  const State before = sim.state();
  REQUIRE_THROWS_AS(sim.step(), SolverError);
  REQUIRE(sim.state().positions == before.positions);
  REQUIRE(sim.steps_taken() == 0);
}

// The volumetric elasticity through SimulationSettings::elasticity: an explicit CPU factory gives
// the bits of the default, on a tissue block and on a coupled scene (shell, rigid plate), for
// backward Euler with Rayleigh damping (the start-of-step tangent comes from the same factory)
// and for a static solve, with iterative and direct (assembled) linear solves.
TEST_CASE("an explicit CPU elasticity factory gives the default's steps bit for bit", "[integrate][backend]") {
  const bool coupled = GENERATE(false, true);
  const LinearMethod method = GENERATE(LinearMethod::pcg, LinearMethod::cholmod);
  const Integrator integrator = GENERATE(Integrator::backward_euler, Integrator::static_equilibrium);
  INFO("coupled " << coupled << ", " << to_string(method) << ", " << to_string(integrator));
  Model model = coupled ? fascia::test::coupled_model(CellType::tetrahedron, true)
                        : fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 3, 2, 1);
  if (!coupled) fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.integrator = integrator;
  settings.dt = 0.01;
  settings.rayleigh_mass = 0.5;
  settings.rayleigh_stiffness = 0.002;
  settings.threads = 2;
  settings.newton.tolerance = 1e-9;
  settings.newton.linear.method = method;

  int made = 0;
  SimulationSettings explicit_settings = settings;
  explicit_settings.elasticity = [&made](const Model& m, int threads, ElasticityUse) {
    ++made;
    return make_cpu_elasticity(m, threads);
  };
  Simulation reference(model, loads, settings), explicit_cpu(model, loads, explicit_settings);
  const int steps = integrator == Integrator::backward_euler ? 3 : 1;
  for (int k = 0; k < steps; ++k) {
    const StepReport a = reference.step(), b = explicit_cpu.step();
    CHECK(a.newton_iterations == b.newton_iterations);
    CHECK(a.cg_iterations == b.cg_iterations);
    CHECK(a.elastic_energy == b.elastic_energy);
  }
  auto same = [](const std::vector<double>& x, const std::vector<double>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
  };
  CHECK(same(reference.state().positions, explicit_cpu.state().positions));
  CHECK(same(reference.state().orientations, explicit_cpu.state().orientations));
  CHECK(same(reference.state().velocities, explicit_cpu.state().velocities));
  // The step's elasticity, and with stiffness-proportional damping the start-of-step one.
  CHECK(made == (integrator == Integrator::backward_euler ? 2 : 1));
  CHECK(reference.state().positions != reference.model().frame_rest_positions);  // it moved
}

TEST_CASE("a step whose energies overflow is a divergence: SolverError, the state keeps the last step", "[integrate]") {
  // A free body moving rigidly at 1e160 m/s: backward Euler's minimiser is the rigid translation
  // h v (the tissue stays undeformed), its velocity is finite, but 1/2 m v^2 overflows to inf.
  const Model model = fascia::test::small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 2, 1, 1);
  SimulationSettings settings;
  settings.integrator = Integrator::backward_euler;
  settings.dt = 1e-3;
  Simulation sim(model, ExternalLoads{}, settings);
  for (int i = 0; i < model.frame_count(); ++i) sim.state().velocities[6 * static_cast<std::size_t>(i)] = 1e160;
  const State before = sim.state();
  try {
    sim.step();
    FAIL("the step was accepted");
  } catch (const SolverError& e) {
    INFO(e.what());
    CHECK_THAT(e.what(), Catch::Contains("non-finite") || Catch::Contains("diverged"));
  }
  REQUIRE(sim.state().positions == before.positions);
  REQUIRE(sim.state().velocities == before.velocities);
  REQUIRE(sim.steps_taken() == 0);
}

// The linear solver changes the path, not the step: every method's backward-Euler step ends
// within the a-posteriori distance of support/minimiser_bound.hpp of the default's. Each state
// satisfies |g_free| <= tau F, so both lie within |g_free| / lambda_min of the exact minimiser;
// frames mapped to the rigid plate move with it, |dx| <= (1 + extent) |dq|.
TEST_CASE("every linear solver gives the same step within the Newton tolerance", "[integrate][solve]") {
  const bool coupled = GENERATE(false, true);
  Model model = coupled ? fascia::test::coupled_model(CellType::tetrahedron, true)
                        : fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 3, 2, 1);
  if (!coupled) fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.dt = 0.01;
  settings.threads = 1;
  settings.newton.tolerance = 1e-9;
  settings.newton.linear.tolerance = 1e-10;
  Simulation reference(model, loads, settings);
  reference.step();
  struct Variant {
    LinearMethod method;
    Preconditioner preconditioner;
  };
  for (const Variant v : {Variant{LinearMethod::pcg, Preconditioner::block_jacobi},
                          Variant{LinearMethod::cholmod, Preconditioner::cholmod},
                          Variant{LinearMethod::cg, Preconditioner::cholmod}}) {
    INFO("coupled " << coupled << ", " << to_string(v.method) << ", " << to_string(v.preconditioner));
    SimulationSettings s = settings;
    s.newton.linear.method = v.method;
    s.newton.linear.preconditioner = v.preconditioner;
    Simulation other(model, loads, s);
    const StepReport r = other.step();
    REQUIRE(r.converged);
    StepPotential probe(reference.model(), reference.loads(), 1);
    probe.set_dynamic(rest_state(reference.model()), settings.dt, 0, 0);
    const fascia::test::MinimiserBound b = fascia::test::minimiser_bound(probe, reference.state(), other.state());
    REQUIRE(b.lambda_min > 0);
    // Round-off of positions of order 0.1 m: a few ulps, 1e-15 m.
    const double bound = (1 + b.extent) * b.distance + 1e-15;
    const fascia::test::StateDifference d = fascia::test::max_difference(reference.state(), other.state());
    INFO("position difference " << d.position << " m, rotation " << d.rotation << " rad, bound " << bound);
    CHECK(d.position <= bound);
    CHECK(d.rotation <= bound);
    // The bound itself is small: the comparison says something.
    CHECK(bound < 1e-6);
  }
}

TEST_CASE("a simulation restored with its reused factorisation continues bit for bit", "[integrate][resume]") {
  // The default linear solver, PCG preconditioned by a CHOLMOD factorisation kept across Newton
  // iterations and steps: a simulation restored from the state, step, time and reused tangent of
  // another one at step 3 repeats its later steps exactly, PCG iterations included.
  const Integrator integrator =
      GENERATE(Integrator::backward_euler, Integrator::static_equilibrium, Integrator::variational);
  INFO(to_string(integrator));
  Model model = fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 3, 2, 1);
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.integrator = integrator;
  settings.dt = 0.01;
  settings.threads = 1;
  settings.load_steps = 2;  // static: a factorisation may be held from load factor 1/2
  settings.rayleigh_mass = integrator == Integrator::variational ? 0.0 : 0.5;
  const fascia::test::ResumeComparison c =
      fascia::test::compare_resume(model, loads, {fascia::test::pull_free_end(model)}, settings, 3, 8);
  REQUIRE(c.held);
  CHECK(c.cg_resumed == c.cg_full);
  CHECK(c.resumed.positions == c.full.positions);  // bitwise
  CHECK(c.resumed.orientations == c.full.orientations);
  CHECK(c.resumed.velocities == c.full.velocities);
  // Static steps extrapolate their start from the last two equilibria, backward Euler holds the
  // last step's force acceleration (step_predictor.hpp): the path history is part of what a
  // restore needs. The variational step makes no guess.
  REQUIRE(c.history == (integrator != Integrator::variational));
  if (c.history) CHECK(c.forgetful.positions != c.full.positions);
  // Without the factorisation the continuation is another one (the checks above can fail): the
  // first solve factorises at the resumed state instead of reusing the held matrix.
  CHECK((c.cg_fresh != c.cg_full || c.fresh.positions != c.full.positions || c.fresh.velocities != c.full.velocities));
}

TEST_CASE("an adaptive simulation restored with its step controller continues bit for bit", "[integrate][resume]") {
  // Adaptive backward Euler or static steps (step_controller.hpp) advanced to k dt, k = 1..8,
  // restored at k = 3 with the controller's state (next step size, rejection flag, counts) and the
  // reused factorisation: the same steps, rejections and PCG iterations follow.
  const Integrator integrator = GENERATE(Integrator::backward_euler, Integrator::static_equilibrium);
  INFO(to_string(integrator));
  Model model = fascia::test::small_box_model(CellType::hexahedron, MaterialLaw::neo_hookean, 3, 2, 1);
  fix_frames(model, [](double x, double, double) { return x < 1e-9; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  SimulationSettings settings;
  settings.integrator = integrator;
  settings.dt = 0.01;
  settings.threads = 1;
  settings.rayleigh_mass = 0.5;
  settings.adaptive.enabled = true;
  // m: several steps per output interval (static: the increment, 5 mm of the pulled end per dt)
  settings.adaptive.tolerance = integrator == Integrator::static_equilibrium ? 2e-3 : 1e-5;
  const fascia::test::ResumeComparison c =
      fascia::test::compare_resume(model, loads, {fascia::test::pull_free_end(model)}, settings, 3, 8);
  CHECK(c.cg_resumed == c.cg_full);
  CHECK(c.resumed.positions == c.full.positions);  // bitwise
  CHECK(c.resumed.orientations == c.full.orientations);
  CHECK(c.resumed.velocities == c.full.velocities);
  // Static steps start from the equilibrium extrapolated from the last two, backward Euler from
  // the motion under the last step's force acceleration (step_predictor.hpp): restored without the
  // previous state, the next step starts elsewhere and converges to other bits.
  REQUIRE(c.history);
  if (c.history) CHECK(c.forgetful.positions != c.full.positions);
}
