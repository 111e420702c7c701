// CG, PCG (block-Jacobi or a reused sparse factorisation) and the CHOLMOD direct solve agree on
// the same projected system; the reused factorisation keeps its symbolic analysis.
#include "integrate/step_potential.hpp"
#include "solve/kept_factorisation.hpp"
#include "solve/linear_solver.hpp"
#include "solve/sparse_cholesky.hpp"
#include "support/finite_difference.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("CG, PCG and CHOLMOD agree on a backward-Euler Newton system", "[solve]") {
  const CellType type = GENERATE(CellType::hexahedron, CellType::tetrahedron);
  Model model = small_box_model(type, MaterialLaw::stvk, 4, 2, 2);
  fix_frames(model, [](double x, double, double) { return x <= 1e-12; });
  const State state = random_state(model, 3, 0.002, 0.05);
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  StepPotential potential(model, loads);
  potential.set_dynamic(rest_state(model), 0.01, 0.0, 0.0);
  std::vector<double> g;
  potential.gradient(state, g);
  potential.prepare_hessian(state);
  const LinearSystem system = potential.system();
  std::vector<double> b(g.size());
  for (size_t k = 0; k < g.size(); ++k) b[k] = model.fixed_dofs[k] ? 0.0 : -g[k];

  std::vector<double> x_direct, x_cg, x_pcg, x_factor;
  LinearSolver solver;
  LinearSettings settings;
  settings.method = LinearMethod::cholmod;
  REQUIRE(solver.solve(system, settings, b, x_direct).converged);
  settings.tolerance = 1e-12;
  settings.max_iterations = 20000;
  settings.method = LinearMethod::cg;
  const LinearResult cg = solver.solve(system, settings, b, x_cg);
  settings.method = LinearMethod::pcg;
  settings.preconditioner = Preconditioner::block_jacobi;
  const LinearResult pcg = solver.solve(system, settings, b, x_pcg);
  settings.preconditioner = Preconditioner::cholmod;
  const LinearResult factor = solver.solve(system, settings, b, x_factor);
  REQUIRE(cg.converged);
  REQUIRE(pcg.converged);
  REQUIRE(factor.converged);
  // Block-Jacobi removes the 1/h^2 mass and the frame's own stiffness scale: fewer iterations.
  REQUIRE(pcg.iterations < cg.iterations);
  // The factorisation of this very H: the preconditioned operator is I up to round-off, so one
  // iteration reaches 1e-12 or, at worst, a second one mops up the round-off.
  REQUIRE(factor.iterations <= 2);
  // With |r| <= 1e-12 |b| the error is bounded by cond(H) * 1e-12 relative; cond(H) of these
  // small models is below 1e4 (mass-dominated at h = 10 ms), hence 1e-8.
  for (size_t k = 0; k < b.size(); ++k) {
    REQUIRE(std::abs(x_cg[k] - x_direct[k]) <= 1e-8 * norm(x_direct));
    REQUIRE(std::abs(x_pcg[k] - x_direct[k]) <= 1e-8 * norm(x_direct));
    REQUIRE(std::abs(x_factor[k] - x_direct[k]) <= 1e-8 * norm(x_direct));
    if (model.fixed_dofs[k]) REQUIRE(x_direct[k] == 0.0);
  }
  // One symbolic analysis served the direct solve and the preconditioner (same pattern).
  REQUIRE(solver.factorisation().analyses() == 1);
}

TEST_CASE("PCG reuses its factorisation at a new state and refreshes it when it stops paying",
          "[solve]") {
  Model model = small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 4, 2, 2);
  fix_frames(model, [](double x, double, double) { return x <= 1e-12; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  StepPotential potential(model, loads);
  potential.set_dynamic(rest_state(model), 0.01, 0.0, 0.0);
  LinearSolver solver;
  LinearSettings settings;
  settings.method = LinearMethod::pcg;
  settings.preconditioner = Preconditioner::cholmod;
  settings.tolerance = 1e-10;
  std::vector<double> g, x, hx(model.dof_count());
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const State state = random_state(model, seed, 0.002, 0.05);
    potential.gradient(state, g);
    potential.prepare_hessian(state);
    const LinearSystem system = potential.system();
    for (size_t k = 0; k < g.size(); ++k) g[k] = model.fixed_dofs[k] ? 0.0 : -g[k];
    const LinearResult r = solver.solve(system, settings, g, x);
    INFO("seed " << seed << ": " << r.iterations << " iterations, " << r.message << ", negative curvature "
                 << r.negative_curvature << ", shifted " << r.shifted);
    REQUIRE(r.converged);
    // The first solve factorises; the later ones precondition with that factorisation of
    // another state's H and must still reach the tolerance: |H x - b| <= 1e-10 |b| on the free DOFs.
    REQUIRE(r.factorised == (seed == 1));
    system.apply(x.data(), hx.data());
    double num = 0, den = 0;
    for (size_t k = 0; k < g.size(); ++k)
      if (!model.fixed_dofs[k]) num += (hx[k] - g[k]) * (hx[k] - g[k]), den += g[k] * g[k];
    REQUIRE(std::sqrt(num / den) <= 1e-10 * (1 + 1e-6));
  }
  // Three solves of a few iterations each repay a factorisation (kCholmodFactorisationCost):
  // the first factorisation serves them all.
  REQUIRE(solver.factorisation().factorisations() == 1);
  REQUIRE(solver.kept().solves == 3);
  REQUIRE(!solver.kept().stale);
  REQUIRE(solver.factorisation().analyses() == 1);
}

TEST_CASE("a kept factorisation is renewed after the first solve that costs more than the mean", "[solve]") {
  // Cost 20 iterations; solves of 2, 4, 6, ... iterations: after solve k the cycle has cost
  // 20 + k (k + 1) over k solves, and solve k's 2k iterations exceed that mean first at k = 6
  // (2k k > 20 + k (k + 1) where k^2 - k > 20: at k = 5 the two are equal, 50 and 50).
  KeptFactorisation kept{false, 0, 0};
  int renewed_after = 0;
  for (int k = 1; k <= 10 && !kept.stale; ++k) {
    ++kept.solves;
    kept.iterations += 2 * k;
    if (stops_paying(kept, 2 * k, 20.0)) {
      kept.stale = true;
      renewed_after = k;
    }
  }
  CHECK(renewed_after == 6);
  CHECK(kept.solves == 6);
  CHECK(kept.iterations == 42);
  // Solves that stay as costly as the first never renew it.
  KeptFactorisation flat{false, 0, 0};
  bool renewed = false;
  for (int k = 1; k <= 1000; ++k) {
    ++flat.solves;
    flat.iterations += 40;
    renewed = renewed || stops_paying(flat, 40, 20.0);
  }
  CHECK_FALSE(renewed);
}

TEST_CASE("CG in fixed-iteration mode runs exactly the requested iterations", "[solve]") {
  Model model = small_box_model(CellType::tetrahedron, MaterialLaw::stvk, 4, 2, 2);
  fix_frames(model, [](double x, double, double) { return x <= 1e-12; });
  ExternalLoads loads;
  loads.gravity = Vec3{0, -9.81, 0};
  StepPotential potential(model, loads);
  const State state = rest_state(model);
  potential.set_dynamic(state, 0.01, 0.0, 0.0);
  std::vector<double> g, x;
  potential.gradient(state, g);
  potential.prepare_hessian(state);
  for (double& v : g) v = -v;
  LinearSettings settings;
  settings.method = LinearMethod::cg;
  settings.fixed_iterations = true;
  settings.max_iterations = 60;
  LinearSolver solver;
  const LinearResult r = solver.solve(potential.system(), settings, g, x);
  REQUIRE(r.iterations == 60);
}

TEST_CASE("an indefinite tangent makes CHOLMOD shift, and CG truncate at negative curvature", "[solve]") {
  // H = diag(1, -1, 2, ...) on 6 DOFs (one frame): not positive definite.
  const std::vector<double> diag{1, -1, 2, 3, 4, 5};
  const std::vector<std::uint8_t> fixed(6, 0);
  LinearSystem system;
  system.size = 6;
  system.fixed = fixed.data();
  system.apply = [&](const double* d, double* out) {
    for (int k = 0; k < 6; ++k) out[k] = diag[k] * d[k];
  };
  system.diagonal_blocks = [&](double* blocks) {
    for (int k = 0; k < 36; ++k) blocks[k] = 0;
    for (int k = 0; k < 6; ++k) blocks[7 * k] = diag[k];
  };
  system.assemble = [&] {
    Eigen::SparseMatrix<double> H(6, 6);
    for (int k = 0; k < 6; ++k) H.insert(k, k) = diag[k];
    return H;
  };
  const std::vector<double> b{1, 1, 1, 1, 1, 1};
  std::vector<double> x;
  LinearSettings settings;
  settings.method = LinearMethod::cholmod;
  LinearSolver solver;
  const LinearResult direct = solver.solve(system, settings, b, x);
  REQUIRE(direct.shifted);
  REQUIRE_THAT(direct.message, Catch::Contains("not positive definite"));
  settings.method = LinearMethod::cg;
  const LinearResult cg = solver.solve(system, settings, b, x);
  REQUIRE(cg.negative_curvature);
  REQUIRE(dot(b, x) > 0);  // still a descent direction for Newton (x solves against -g = b)

  // PCG with the shifted factorisation meets the negative curvature too, and returns the
  // shifted matrix's step F^{-1} b, F = H + tau diag|H| (the modified Newton step), as the
  // direct solve does.
  settings.method = LinearMethod::pcg;
  settings.preconditioner = Preconditioner::cholmod;
  LinearSolver kept;
  const LinearResult modified = kept.solve(system, settings, b, x);
  REQUIRE(modified.negative_curvature);
  REQUIRE(modified.shifted);
  const double tau = kept.factorisation().shift();
  REQUIRE(tau > 1);  // the smallest shift that makes -1 + tau positive
  for (int k = 0; k < 6; ++k) {
    const double expected = b[k] / (diag[k] + tau * std::abs(diag[k]));
    CHECK(std::abs(x[k] - expected) <= 4e-16 * std::abs(expected));  // one division, rounded
  }
  REQUIRE(dot(b, x) > 0);
}
