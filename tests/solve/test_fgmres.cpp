// FGMRES (solve/fgmres.hpp) on non-symmetric systems, against Eigen's dense LU of the free block.
#include "solve/fgmres.hpp"
#include "solve/vector_ops.hpp"

#include <catch2/catch.hpp>

#include <Eigen/Dense>

#include <cmath>
#include <vector>

using namespace fascia;

namespace {

// Convection-diffusion on n points: A = tridiag(-1 - c, 2 + s, -1 + c), non-symmetric for c != 0.
struct ConvectionDiffusion {
  int n;
  double c, s;
  Eigen::MatrixXd dense() const {
    Eigen::MatrixXd A = Eigen::MatrixXd::Zero(n, n);
    for (int k = 0; k < n; ++k) {
      A(k, k) = 2 + s;
      if (k > 0) A(k, k - 1) = -1 - c;
      if (k + 1 < n) A(k, k + 1) = -1 + c;
    }
    return A;
  }
};

// The free block's solution (fixed rows and columns removed), zero at fixed DOFs.
std::vector<double> reference(const Eigen::MatrixXd& A, const std::vector<double>& b, const std::vector<std::uint8_t>& fixed) {
  std::vector<int> free;
  for (int k = 0; k < static_cast<int>(b.size()); ++k)
    if (!fixed[k]) free.push_back(k);
  const int m = static_cast<int>(free.size());
  Eigen::MatrixXd Af(m, m);
  Eigen::VectorXd bf(m);
  for (int i = 0; i < m; ++i) {
    bf[i] = b[free[i]];
    for (int j = 0; j < m; ++j) Af(i, j) = A(free[i], free[j]);
  }
  const Eigen::VectorXd xf = Af.partialPivLu().solve(bf);
  std::vector<double> x(b.size(), 0.0);
  for (int i = 0; i < m; ++i) x[free[i]] = xf[i];
  return x;
}

// |b - A x| / |b| on the free DOFs.
double true_residual(const Eigen::MatrixXd& A, const std::vector<double>& b, const std::vector<double>& x,
                     const std::vector<std::uint8_t>& fixed) {
  double r2 = 0, b2 = 0;
  for (int i = 0; i < A.rows(); ++i) {
    if (fixed[i]) continue;
    double ax = 0;
    for (int j = 0; j < A.cols(); ++j) ax += A(i, j) * x[j];
    r2 += (b[i] - ax) * (b[i] - ax);
    b2 += b[i] * b[i];
  }
  return std::sqrt(r2 / b2);
}

}  // namespace

TEST_CASE("FGMRES solves a non-symmetric system on the free DOFs", "[solve][fgmres]") {
  const ConvectionDiffusion problem{40, 0.6, 0.05};
  const Eigen::MatrixXd A = problem.dense();
  std::vector<std::uint8_t> fixed(40, 0);
  fixed[0] = fixed[17] = 1;
  const HostVectorOps ops(40, fixed.data());
  std::vector<double> b(40);
  for (int k = 0; k < 40; ++k) b[k] = std::sin(0.3 * k) + 0.1 * k;
  const std::vector<double> expected = reference(A, b, fixed);
  auto apply = [&](const std::vector<double>& z, std::vector<double>& out) {
    out.assign(40, 0.0);
    for (int i = 0; i < 40; ++i)
      for (int j = 0; j < 40; ++j) out[i] += A(i, j) * z[j];
    return true;
  };
  FgmresSettings settings;
  settings.tolerance = 1e-10;
  settings.max_iterations = 40;
  std::vector<double> x;
  int calls = 0;
  auto identity = [&](const std::vector<double>& v, std::vector<double>& z) {
    z = v;
    ++calls;
    return 0;
  };

  SECTION("unpreconditioned: at most one iteration per free DOF") {
    const LinearResult r = fgmres(ops, apply, identity, settings, b, x);
    REQUIRE(r.converged);
    REQUIRE(calls <= 38);
    REQUIRE(x[0] == 0.0);
    REQUIRE(x[17] == 0.0);
    // The rotations' residual is the true one (to round-off of a 40 x 40 system, cond ~ 1e3).
    REQUIRE(true_residual(A, b, x, fixed) <= 1e-10 * 1.01 + 1e-13);
    REQUIRE(true_residual(A, b, x, fixed) == Approx(r.relative_residual).margin(1e-12));
    for (int k = 0; k < 40; ++k) REQUIRE(x[k] == Approx(expected[k]).margin(1e-8));
  }
  SECTION("a preconditioner that changes every iteration (flexible), its iterations counted") {
    // Damped Jacobi sweeps, one more each call: a different M_j^{-1} per iteration, which right-
    // preconditioned GMRES would not allow and FGMRES does.
    int sweeps = 0;
    auto jacobi = [&](const std::vector<double>& v, std::vector<double>& z) {
      ++sweeps;
      z.assign(40, 0.0);
      for (int sweep = 0; sweep < sweeps; ++sweep) {
        std::vector<double> next(40, 0.0);
        for (int i = 0; i < 40; ++i) {
          double off = 0;
          for (int j = 0; j < 40; ++j)
            if (j != i) off += A(i, j) * z[j];
          next[i] = z[i] + 0.8 * ((v[i] - off) / A(i, i) - z[i]);
        }
        z = next;
      }
      return sweeps;
    };
    const LinearResult r = fgmres(ops, apply, jacobi, settings, b, x);
    REQUIRE(r.converged);
    REQUIRE(r.iterations == sweeps * (sweeps + 1) / 2);  // 1 + 2 + ... + sweeps inner iterations
    REQUIRE(true_residual(A, b, x, fixed) == Approx(r.relative_residual).margin(1e-12));
    for (int k = 0; k < 40; ++k) REQUIRE(x[k] == Approx(expected[k]).margin(1e-8));
  }
  SECTION("capped: the best iterate of the Krylov space, its residual as reported") {
    settings.max_iterations = 5;
    const LinearResult r = fgmres(ops, apply, identity, settings, b, x);
    REQUIRE(!r.converged);
    REQUIRE(r.message == "GMRES reached its iteration cap");
    REQUIRE(!r.product_failed);
    REQUIRE(r.relative_residual < 1);  // GMRES's residual never grows
    REQUIRE(true_residual(A, b, x, fixed) == Approx(r.relative_residual).margin(1e-12));
  }
  SECTION("a product that cannot be formed stops the solve with x = 0") {
    int products = 0;
    auto failing = [&](const std::vector<double>& z, std::vector<double>& out) {
      return ++products < 3 && apply(z, out);
    };
    const LinearResult r = fgmres(ops, failing, identity, settings, b, x);
    REQUIRE(!r.converged);
    REQUIRE(r.product_failed);
    for (double v : x) REQUIRE(v == 0.0);
  }
}

TEST_CASE("FGMRES: a zero operator leaves the residual at |b|, reported as such", "[solve][fgmres]") {
  const HostVectorOps ops(4, nullptr);
  auto zero = [](const std::vector<double>& z, std::vector<double>& out) {
    out.assign(z.size(), 0.0);
    return true;
  };
  auto identity = [](const std::vector<double>& v, std::vector<double>& z) {
    z = v;
    return 0;
  };
  std::vector<double> x;
  const LinearResult r = fgmres(ops, zero, identity, FgmresSettings{}, std::vector<double>{1, 2, 0, -1}, x);
  REQUIRE(!r.converged);
  REQUIRE(r.relative_residual == 1.0);
  for (double v : x) REQUIRE(v == 0.0);
}

TEST_CASE("FGMRES: the identity converges in one iteration, a zero right-hand side in none", "[solve][fgmres]") {
  const HostVectorOps ops(6, nullptr);
  auto identity_product = [](const std::vector<double>& z, std::vector<double>& out) {
    out = z;
    return true;
  };
  int preconditions = 0;
  auto identity = [&](const std::vector<double>& v, std::vector<double>& z) {
    z = v;
    ++preconditions;
    return 0;
  };
  std::vector<double> b{1, -2, 3, 0.5, 0, 4}, x;
  LinearResult r = fgmres(ops, identity_product, identity, FgmresSettings{}, b, x);
  REQUIRE(r.converged);  // a breakdown at the first iteration: x_1 solves the system
  REQUIRE(preconditions == 1);
  for (int k = 0; k < 6; ++k) REQUIRE(x[k] == Approx(b[k]).epsilon(1e-15));
  preconditions = 0;
  r = fgmres(ops, identity_product, identity, FgmresSettings{}, std::vector<double>(6, 0.0), x);
  REQUIRE(r.converged);
  REQUIRE(preconditions == 0);
  for (double v : x) REQUIRE(v == 0.0);
}
