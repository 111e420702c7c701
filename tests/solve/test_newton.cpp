// The one Newton (solve/newton.hpp) on a problem of its own state type, which is what a second
// backend provides: Phi(x) = sum_k x_k^4 / 4 + a_k x_k^2 / 2 - f b_k x_k, strictly convex, with
// the exact minimiser known per component (the real root of x^3 + a x = f b).
#include "solve/newton.hpp"
#include "solve/vector_ops.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

using namespace fascia;

namespace {

struct QuarticProblem {
  using Ops = HostVectorOps;
  using Vector = std::vector<double>;
  using State = std::vector<double>;  // x itself: retract is x + alpha d

  std::vector<double> a, b;
  std::vector<std::uint8_t> fixed;
  double f = 1;                 // load factor times load scale
  bool potential = true;        // minimises(): false runs the residual line search
  int solves = 0;
  HostVectorOps m_ops;

  QuarticProblem(int n, double load) : a(n), b(n), fixed(n, 0), f(load), m_ops(n, nullptr) {
    for (int k = 0; k < n; ++k) a[k] = 0.5 + 0.1 * k, b[k] = std::cos(0.7 * k);
    fixed[2] = 1;
    m_ops = HostVectorOps(n, fixed.data());
  }
  const Ops& ops() const { return m_ops; }
  bool minimises() const { return potential; }
  mutable int values = 0, gradients = 0;  // calls of value() and gradient()
  double phi(const State& x) const {
    double s = 0;
    for (size_t k = 0; k < x.size(); ++k) s += 0.25 * std::pow(x[k], 4) + 0.5 * a[k] * x[k] * x[k] - f * b[k] * x[k];
    return s;
  }
  double value(const State& x) const {
    ++values;
    return phi(x);
  }
  double gradient(const State& x, Vector& g) const {
    ++gradients;
    g.resize(x.size());
    for (size_t k = 0; k < x.size(); ++k) g[k] = x[k] * x[k] * x[k] + a[k] * x[k] - f * b[k];
    m_ops.project(g);
    return phi(x);
  }
  // The exact Newton step, or with `inexact` one whose residual is the tolerance asked for:
  // d = (1 + tolerance) H^{-1} rhs, so |H d - rhs| = tolerance |rhs|.
  bool inexact = false;
  std::vector<double> tolerances, rhs_norms;  // per solve: the tolerance asked, |rhs|
  LinearResult solve(const State& x, const Vector& rhs, Vector& d, const LinearSettings& linear) {
    ++solves;
    const double tolerance = linear.tolerance;
    tolerances.push_back(tolerance);
    rhs_norms.push_back(m_ops.norm(rhs));
    const double scale = inexact ? 1 + tolerance : 1.0;
    d.resize(x.size());
    for (size_t k = 0; k < x.size(); ++k) d[k] = fixed[k] ? 0.0 : scale * rhs[k] / (3 * x[k] * x[k] + a[k]);
    LinearResult r;
    r.converged = true;
    r.iterations = 1;
    return r;
  }
  void retract(State& x, const Vector& d, double alpha) const {
    for (size_t k = 0; k < x.size(); ++k) x[k] += alpha * d[k];
  }
  // The real root of x^3 + a x - c (Cardano; one real root since a > 0).
  double root(int k) const {
    const double p = a[k], q = -f * b[k];
    const double s = std::sqrt(q * q / 4 + p * p * p / 27);
    return std::cbrt(-q / 2 + s) + std::cbrt(-q / 2 - s);
  }
};

// A residual problem whose solve is an approximation of its Jacobian, as the variational step's
// symmetric iteration matrix is: g(x) = (D + w W) x + x^3 - b (componentwise cube), W the skew
// rotation generator of each pair (2i, 2i+1), D = diag(1, 4, 1, 4, ...). J = D + w W + 3 diag(x^2);
// solve() uses its symmetric part D + 3 diag(x^2) alone. At x = 0, with b alternating in sign,
// g^T J d = -|b|^2 + w sum_i (1/d_2i - 1/d_2i+1) |b_2i b_2i+1| for the symmetric direction
// d = D^{-1} b: positive (no step along d decreases |g|) for w above about 2.7.
struct SkewProblem {
  using Ops = HostVectorOps;
  using Vector = std::vector<double>;
  using State = std::vector<double>;

  int n;
  double w;
  std::vector<double> b;
  std::vector<std::uint8_t> fixed;
  HostVectorOps m_ops;
  int solves = 0, gradients = 0;

  SkewProblem(int size, double skew) : n(size), w(skew), b(size), fixed(size, 0), m_ops(size, nullptr) {
    for (int k = 0; k < n; ++k) b[k] = (k % 2 == 0 ? 1.0 : -1.0) * (1 + 0.1 * k);
    fixed[n - 1] = 1;
    m_ops = HostVectorOps(n, fixed.data());
  }
  const Ops& ops() const { return m_ops; }
  bool minimises() const { return false; }
  double value(const State&) const { return 0; }
  double d(int k) const { return k % 2 == 0 ? 1.0 : 4.0; }
  // (W x)_{2i} = -x_{2i+1}, (W x)_{2i+1} = x_{2i}.
  double skew_product(const std::vector<double>& x, int k) const {
    if (k % 2 == 0) return k + 1 < n ? -x[k + 1] : 0.0;
    return x[k - 1];
  }
  double gradient(const State& x, Vector& g) {
    ++gradients;
    g.resize(n);
    for (int k = 0; k < n; ++k) g[k] = d(k) * x[k] + w * skew_product(x, k) + x[k] * x[k] * x[k] - b[k];
    m_ops.project(g);
    return 0;
  }
  LinearResult solve(const State& x, const Vector& rhs, Vector& dx, const LinearSettings&) {
    ++solves;
    dx.resize(n);
    for (int k = 0; k < n; ++k) dx[k] = fixed[k] ? 0.0 : rhs[k] / (d(k) + 3 * x[k] * x[k]);
    LinearResult r;
    r.converged = true;
    r.iterations = 1;
    return r;
  }
  void retract(State& x, const Vector& dx, double alpha) const {
    for (int k = 0; k < n; ++k) x[k] += alpha * dx[k];
  }
  // g^T J d: negative where d decreases |g|^2 = g^T g.
  double descent(const State& x, const Vector& g, const Vector& dx) const {
    double s = 0;
    for (int k = 0; k < n; ++k)
      if (!fixed[k]) s += g[k] * ((d(k) + 3 * x[k] * x[k]) * dx[k] + w * skew_product(dx, k));
    return s;
  }
};

}  // namespace

TEST_CASE("Newton on a residual problem: Newton-Krylov directions where the approximate solve's fail",
          "[solve][newton]") {
  NewtonSettings settings;
  settings.tolerance = 1e-10;
  SECTION("a good approximation: its own directions, one solve and one residual per iteration") {
    SkewProblem problem(10, 0.05);
    std::vector<double> x(10, 0.0);
    const NewtonResult r = newton(problem, x, settings, 1.0);
    REQUIRE(r.converged());
    REQUIRE(problem.solves == r.iterations);
    REQUIRE(r.cg_iterations == problem.solves);
  }
  SECTION("a poor approximation: its first direction ascends on |g|, the Newton-Krylov ones converge") {
    SkewProblem problem(10, 8.0);
    std::vector<double> x(10, 0.0), g, dx, rhs;
    problem.gradient(x, g);
    rhs = g;
    for (double& v : rhs) v = -v;
    problem.solve(x, rhs, dx, settings.linear);
    REQUIRE(problem.descent(x, g, dx) > 0);  // no step along it decreases |g|: its line search fails
    problem.solves = problem.gradients = 0;
    x[9] = 0.5;  // a fixed DOF keeps its value
    const NewtonResult r = newton(problem, x, settings, 1.0);
    INFO(r.message);
    REQUIRE(r.converged());
    REQUIRE(x[9] == 0.5);
    problem.gradient(x, g);
    REQUIRE(problem.ops().norm(g) <= 1e-10 * r.scale);
    // Each FGMRES iteration preconditions once (counted one iteration each here).
    REQUIRE(problem.solves > r.iterations);
    REQUIRE(r.cg_iterations == problem.solves);
    // The symmetric directions reduce |g| by 2e-4 at the first iteration (by a short step, before
    // the ascent takes over) and ever less after it, until a line search fails (iteration 13,
    // |g| 0.79 |g_0|); from there Newton-Krylov converges quadratically, in 4 iterations to
    // 1e-10 (16 in all).
    REQUIRE(r.iterations <= 20);
  }
}

// A residual problem without a root: g(x) = (1 + x_1^2, x_1). |g| has its minimum 1 at x_1 = 0,
// where J = [0 0; 0 1] and J^T g = 0. solve() approximates J by the identity, whose first step
// lands on x_1 = 0; no step decreases |g| from there.
struct RootlessProblem {
  using Ops = HostVectorOps;
  using Vector = std::vector<double>;
  using State = std::vector<double>;
  HostVectorOps m_ops{2, nullptr};
  const Ops& ops() const { return m_ops; }
  bool minimises() const { return false; }
  double value(const State&) const { return 0; }
  double gradient(const State& x, Vector& g) const {
    g = {1 + x[1] * x[1], x[1]};
    return 0;
  }
  LinearResult solve(const State&, const Vector& rhs, Vector& d, const LinearSettings&) const {
    d = rhs;
    LinearResult r;
    r.converged = true;
    r.iterations = 1;
    return r;
  }
  void retract(State& x, const Vector& d, double alpha) const {
    for (int k = 0; k < 2; ++k) x[k] += alpha * d[k];
  }
};

TEST_CASE("Newton reports why it stopped", "[solve][newton]") {
  NewtonSettings settings;
  settings.tolerance = 1e-10;
  SECTION("the iteration cap") {
    settings.max_iterations = 6;  // too few for the load 200 from x = 0
    QuarticProblem problem(8, 200.0);
    std::vector<double> x(8, 0.0);
    const NewtonResult r = newton(problem, x, settings, 1.0);
    REQUIRE(!r.converged());
    REQUIRE(r.stop == NewtonStop::iteration_cap);
  }
  SECTION("a starting state that is not admissible") {
    QuarticProblem problem(8, 1.0);
    std::vector<double> x(8, 0.0);
    x[0] = std::numeric_limits<double>::quiet_NaN();
    const NewtonResult r = newton(problem, x, settings, 1.0);
    REQUIRE(!r.converged());
    REQUIRE(r.stop == NewtonStop::inadmissible_start);
  }
  SECTION("a residual without a root: Newton-Krylov stops at the minimum of |g|") {
    RootlessProblem problem;
    std::vector<double> x{0.3, 0.5};
    const NewtonResult r = newton(problem, x, settings, 1.0);
    INFO(r.message);
    REQUIRE(!r.converged());
    REQUIRE(r.stop == NewtonStop::krylov_stall);
    REQUIRE(x[1] == 0.0);  // left at the minimum of |g|
  }
}

TEST_CASE("Newton minimises a strictly convex potential to its tolerance", "[solve][newton]") {
  const bool potential = GENERATE(true, false);
  QuarticProblem problem(8, 20.0);
  problem.potential = potential;
  std::vector<double> x(8, 0.0);
  x[2] = 0.25;  // a fixed DOF keeps its value
  NewtonSettings settings;
  settings.tolerance = 1e-10;
  const NewtonResult r = newton(problem, x, settings, 1.0);
  REQUIRE(r.converged());
  REQUIRE(r.stop == NewtonStop::converged);
  REQUIRE(r.iterations == problem.solves);
  REQUIRE(r.cg_iterations == problem.solves);
  REQUIRE(x[2] == 0.25);
  std::vector<double> g;
  problem.gradient(x, g);
  // Converged means |g| <= tolerance * max(reference 1 N, |g_0|); |g_0| = 20 |b| here.
  const double g0 = 20.0 * std::sqrt(std::inner_product(problem.b.begin(), problem.b.end(), problem.b.begin(), 0.0) -
                                     problem.b[2] * problem.b[2]);
  REQUIRE(problem.ops().norm(g) <= 1e-10 * g0);
  // |x - x*| <= |g| / min curvature (a_min = 0.5) per component.
  for (int k = 0; k < 8; ++k)
    if (k != 2) REQUIRE(std::abs(x[k] - problem.root(k)) <= 2 * 1e-10 * g0 / 0.5);
  // Newton's local quadratic convergence: a handful of iterations from x = 0 even at f = 20.
  REQUIRE(r.iterations <= 15);
}

TEST_CASE("Newton's accepted full steps cost one gradient each and no separate value", "[solve][newton]") {
  // The gradient returns Phi too: a full step is tested for sufficient decrease with the Phi of
  // its gradient, which, accepted, serves the next iteration. Only shortened steps evaluate Phi
  // alone. A mild load (every full step accepted): one gradient at the start and one per iteration.
  // A load of 20 from x = 0 shortens some steps: each halving evaluates Phi once, and a rejected
  // full step's gradient is the one extra gradient per shortened iteration.
  const double load = GENERATE(0.5, 20.0);
  QuarticProblem problem(8, load);
  std::vector<double> x(8, 0.0);
  NewtonSettings settings;
  settings.tolerance = 1e-10;
  const NewtonResult r = newton(problem, x, settings, 1.0);
  REQUIRE(r.converged());
  if (load < 1) {
    REQUIRE(problem.values == 0);
    REQUIRE(problem.gradients == r.iterations + 1);
  } else {
    REQUIRE(problem.values > 0);
    REQUIRE(problem.gradients <= 2 * r.iterations + 1);
    REQUIRE(problem.gradients >= r.iterations + 1);
  }
}

TEST_CASE("Newton's forcing term: loose far from the minimum, tighter near it, the tolerance's last",
          "[solve][newton]") {
  NewtonSettings settings;
  settings.tolerance = 1e-10;
  QuarticProblem exact(8, 20.0), inexact(8, 20.0);
  inexact.inexact = true;
  std::vector<double> x_exact(8, 0.0), x(8, 0.0);
  const NewtonResult r_exact = newton(exact, x_exact, settings, 1.0);
  const NewtonResult r = newton(inexact, x, settings, 1.0);
  REQUIRE(r_exact.converged());
  REQUIRE(r.converged());
  // Solve k was asked for eta_k = min(kForcingMax, max(kForcing r_k, kForcingFloor tol / r_k)),
  // at least the linear tolerance, with r_k = |g_k| / scale, scale = max(reference 1 N, |g_0|)
  // and |g_k| = |rhs_k|.
  REQUIRE(inexact.rhs_norms.size() == inexact.tolerances.size());
  REQUIRE(inexact.rhs_norms.size() >= 3);
  const double scale = std::max(1.0, inexact.rhs_norms.front());
  for (size_t k = 0; k < inexact.tolerances.size(); ++k) {
    const double r_k = inexact.rhs_norms[k] / scale;
    const double expected = std::max(
        settings.linear.tolerance, std::min(kForcingMax, std::max(kForcing * r_k, kForcingFloor * settings.tolerance / r_k)));
    REQUIRE(inexact.tolerances[k] == Approx(expected).epsilon(1e-15));
  }
  REQUIRE(inexact.tolerances.front() == kForcingMax);  // |g_0| = scale: the cap
  int proportional = 0;  // solves between the cap and the floor: kForcing r_k, shrinking with r_k
  for (size_t k = 0; k < inexact.tolerances.size(); ++k) {
    const double r_k = inexact.rhs_norms[k] / scale;
    if (inexact.tolerances[k] < kForcingMax && inexact.tolerances[k] == Approx(kForcing * r_k).epsilon(1e-15)) ++proportional;
  }
  REQUIRE(proportional >= 1);
  // The last solve, near the minimum, is asked for the Newton tolerance and no more: its eta is
  // the floor, kForcingFloor tol / r_k, above kForcing r_k.
  const double r_last = inexact.rhs_norms.back() / scale;
  REQUIRE(kForcingFloor * settings.tolerance / r_last > kForcing * r_last);
  REQUIRE(inexact.tolerances.back() == Approx(kForcingFloor * settings.tolerance / r_last).epsilon(1e-15));
  // Residuals of eta_k |g_k| keep the quadratic convergence: at most one more iteration than
  // exact solves, and the same minimiser to the tolerance.
  REQUIRE(r.iterations <= r_exact.iterations + 1);
  for (int k = 0; k < 8; ++k)
    if (k != 2) REQUIRE(std::abs(x[k] - inexact.root(k)) <= 2 * 1e-10 * scale / 0.5);
}

TEST_CASE("Newton in fixed-iteration mode takes exactly that many full steps", "[solve][newton]") {
  QuarticProblem problem(6, 1.0);
  std::vector<double> x(6, 0.0);
  NewtonSettings settings;
  settings.fixed_iterations = 2;
  const NewtonResult r = newton(problem, x, settings, 1.0);
  REQUIRE(r.converged());
  REQUIRE(r.iterations == 2);
  // Two undamped Newton steps from 0: x1 = f b / a, x2 = x1 - (x1^3 + a x1 - f b) / (3 x1^2 + a).
  for (int k = 0; k < 6; ++k) {
    if (k == 2) continue;
    const double x1 = problem.b[k] / problem.a[k];
    const double x2 = x1 - (x1 * x1 * x1 + problem.a[k] * x1 - problem.b[k]) / (3 * x1 * x1 + problem.a[k]);
    REQUIRE(x[k] == Approx(x2).epsilon(1e-14));
  }
}

TEST_CASE("load stepping halves the load increment until Newton converges within its budget", "[solve][newton]") {
  QuarticProblem problem(8, 0.0);
  std::vector<double> x(8, 0.0);
  NewtonSettings settings;
  settings.tolerance = 1e-10;
  settings.max_iterations = 6;  // too few for the full load 200 from x = 0
  {
    QuarticProblem direct(8, 200.0);
    std::vector<double> y(8, 0.0);
    REQUIRE(!newton(direct, y, settings, 1.0).converged());
  }
  std::vector<double> factors;
  LoadStepping stepping;
  const NewtonResult r = newton_load_stepping(problem, x, settings, stepping, [&](double factor) {
    factors.push_back(factor);
    problem.f = 200.0 * factor;
    return 1.0;
  });
  REQUIRE(r.converged());
  REQUIRE(factors.size() > 1);
  REQUIRE(factors.back() == 1.0);
  REQUIRE(problem.f == 200.0);
  std::vector<double> g;
  problem.gradient(x, g);
  for (int k = 0; k < 8; ++k)
    if (k != 2) REQUIRE(std::abs(x[k] - problem.root(k)) <= 1e-6 * std::abs(problem.root(k)));
}
