// The one PCG (solve/pcg.hpp) over HostVectorOps on small matrices whose CG behaviour is known
// exactly.
#include "solve/pcg.hpp"
#include "solve/vector_ops.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

using namespace fascia;

namespace {

// A symmetric positive definite matrix with eigenvalues 1, 2 and 4 (orthogonal similarity of a
// diagonal one by a Householder reflection, so the matrix is dense): CG converges in as many
// iterations as there are distinct eigenvalues (Saad, Iterative Methods, §6.11.3), here 3.
struct DenseOperator {
  int n;
  std::vector<double> a;  // [n][n]
  void operator()(const std::vector<double>& x, std::vector<double>& y) const {
    for (int r = 0; r < n; ++r) {
      double s = 0;
      for (int c = 0; c < n; ++c) s += a[n * r + c] * x[c];
      y[r] = s;
    }
  }
};

DenseOperator three_eigenvalue_matrix(int n) {
  std::vector<double> v(n);
  double vv = 0;
  for (int k = 0; k < n; ++k) vv += (v[k] = 1.0 + 0.3 * k);
  vv = 0;
  for (double x : v) vv += x * x;
  DenseOperator op{n, std::vector<double>(n * n)};
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      // Q = I - 2 v v^T / v^T v, A = Q D Q with D = diag(1, 2, 4, 1, 2, 4, ...).
      double s = 0;
      for (int k = 0; k < n; ++k) {
        const double qrk = (r == k) - 2 * v[r] * v[k] / vv, qkc = (k == c) - 2 * v[k] * v[c] / vv;
        s += qrk * static_cast<double>(1 << (k % 3)) * qkc;
      }
      op.a[n * r + c] = s;
    }
  return op;
}

}  // namespace

TEST_CASE("PCG converges in as many iterations as the operator has distinct eigenvalues", "[solve][pcg]") {
  const int n = 12;
  const DenseOperator A = three_eigenvalue_matrix(n);
  const HostVectorOps ops(n, nullptr);
  std::vector<double> b(n), x;
  for (int k = 0; k < n; ++k) b[k] = std::sin(1.0 + k);
  PcgSettings settings;
  settings.tolerance = 1e-12;
  const LinearResult r = pcg(ops, A, IdentityPreconditioner<HostVectorOps>{ops}, settings, b, x);
  REQUIRE(r.converged);
  REQUIRE(r.iterations == 3);
  std::vector<double> ax(n);
  A(x, ax);
  // cond(A) = 4, so |x - x*| <= 4 |r| / |b| relative; the check is on the residual itself with
  // the tolerance asked for, plus round-off of the dense product (n eps |A| |x| ~ 1e-14).
  for (int k = 0; k < n; ++k) REQUIRE(std::abs(ax[k] - b[k]) <= 1e-11);
}

TEST_CASE("PCG keeps fixed DOFs at zero and solves the free block", "[solve][pcg]") {
  const int n = 12;
  const DenseOperator A = three_eigenvalue_matrix(n);
  std::vector<std::uint8_t> fixed(n, 0);
  fixed[0] = fixed[5] = fixed[11] = 1;
  const HostVectorOps ops(n, fixed.data());
  std::vector<double> b(n, 1.0), x;  // b is nonzero at fixed DOFs: pcg projects it
  // Jacobi (diagonal) preconditioner.
  auto jacobi = [&](const std::vector<double>& r, std::vector<double>& z) {
    for (int k = 0; k < n; ++k) z[k] = r[k] / A.a[n * k + k];
  };
  PcgSettings settings;
  settings.tolerance = 1e-12;
  const LinearResult r = pcg(ops, A, jacobi, settings, b, x);
  REQUIRE(r.converged);
  std::vector<double> ax(n);
  A(x, ax);
  for (int k = 0; k < n; ++k) {
    if (fixed[k]) {
      REQUIRE(x[k] == 0.0);
    } else {
      REQUIRE(std::abs(ax[k] - 1.0) <= 1e-10);  // the free rows of A x = b, as above
    }
  }
}

TEST_CASE("PCG in fixed-iteration mode runs exactly the requested iterations", "[solve][pcg]") {
  const int n = 12;
  const DenseOperator A = three_eigenvalue_matrix(n);
  const HostVectorOps ops(n, nullptr);
  std::vector<double> b(n, 1.0), x;
  PcgSettings settings;
  settings.fixed_iterations = true;
  settings.max_iterations = 2;
  const LinearResult r = pcg(ops, A, IdentityPreconditioner<HostVectorOps>{ops}, settings, b, x);
  REQUIRE(r.iterations == 2);
  REQUIRE(r.relative_residual > 1e-6);  // 2 < 3 distinct eigenvalues: not solved yet
}

TEST_CASE("PCG truncates at non-positive curvature with a descent direction", "[solve][pcg]") {
  const std::vector<double> diag{1, -1, 2, 3, 4, 5};
  const HostVectorOps ops(6, nullptr);
  auto apply = [&](const std::vector<double>& x, std::vector<double>& y) {
    for (int k = 0; k < 6; ++k) y[k] = diag[k] * x[k];
  };
  const std::vector<double> b{1, 1, 1, 1, 1, 1};
  std::vector<double> x;
  const LinearResult r = pcg(ops, apply, IdentityPreconditioner<HostVectorOps>{ops}, PcgSettings{}, b, x);
  REQUIRE(r.negative_curvature);
  REQUIRE(!r.converged);
  REQUIRE(ops.dot(b, x) > 0);  // descent for Newton, which solves H d = -g = b
}

namespace {

// HostVectorOps whose PCG scalars count as a device's: pcg reads them at the iterations
// next_status_read schedules, not after each one.
struct DeferredReadOps : HostVectorOps {
  using HostVectorOps::HostVectorOps;
  static constexpr bool kScalarsOnHost = false;
  mutable int reads = 0;
  CgStatus cg_status(const CgScalars& s) const {
    ++reads;
    return HostVectorOps::cg_status(s);
  }
};

// A diagonal operator with eigenvalues spread over [1, 1000] (CG takes tens of iterations), one
// of them -1 at `negative` (>= 0) to break down there.
struct SpreadOperator {
  int n, negative;
  double eigenvalue(int k) const { return k == negative ? -1.0 : std::pow(1000.0, static_cast<double>(k) / (n - 1)); }
  void operator()(const std::vector<double>& x, std::vector<double>& y) const {
    for (int k = 0; k < n; ++k) y[k] = eigenvalue(k) * x[k];
  }
};

}  // namespace

TEST_CASE("next_status_read predicts the iterations to the tolerance at the rate seen", "[solve][pcg]") {
  // Rate 0.1 per iteration: from 1e-2 at iteration 2, 1e-8 is 6 iterations away.
  CHECK(next_status_read(0, 1.0, 2, 1e-2, 1e-8) == 6);
  CHECK(next_status_read(0, 1.0, 1, 0.5, 1e-8) == kMaxIterationsBetweenReads);  // far: the cap
  CHECK(next_status_read(4, 1e-3, 5, 1e-3, 1e-8) == 1);                        // no progress: every one
  CHECK(next_status_read(4, 1e-3, 5, 2e-3, 1e-8) == 1);                        // growing
  CHECK(next_status_read(4, 1e-3, 5, 1e-9, 1e-8) == 1);                        // already there
  CHECK(next_status_read(0, 1.0, 3, 1e-7, 1e-8) == 1);                         // 1/3 of an iteration: next
}

TEST_CASE("PCG reading its scalars only now and then returns what reading every iteration does",
          "[solve][pcg]") {
  const int n = 60;
  for (const int negative : {-1, 0, 17}) {
    for (const bool fixed : {false, true}) {
      for (const int cap : {5, 2000}) {
        CAPTURE(negative, fixed, cap);
        const SpreadOperator A{n, negative};
        std::vector<double> b(n);
        for (int k = 0; k < n; ++k) b[k] = std::cos(0.3 + k);
        PcgSettings settings;
        settings.tolerance = 1e-10;
        settings.fixed_iterations = fixed;
        settings.max_iterations = cap;
        const HostVectorOps every(n, nullptr);
        const DeferredReadOps deferred(n, nullptr);
        std::vector<double> x_every, x_deferred;
        const LinearResult a = pcg(every, A, IdentityPreconditioner<HostVectorOps>{every}, settings, b, x_every);
        const LinearResult d =
            pcg(deferred, A, IdentityPreconditioner<DeferredReadOps>{deferred}, settings, b, x_deferred);
        CHECK(d.iterations == a.iterations);
        CHECK(d.relative_residual == a.relative_residual);
        CHECK(d.converged == a.converged);
        CHECK(d.negative_curvature == a.negative_curvature);
        CHECK(d.message == a.message);
        CHECK(x_deferred == x_every);  // bitwise: the iterations after the stop change nothing
        if (negative < 0 && !fixed && cap > 100) {
          REQUIRE(a.converged);
          CHECK(a.iterations > 20);
          CHECK(deferred.reads < a.iterations / 2);  // most iterations ran without a read
        }
      }
    }
  }
}

TEST_CASE("PCG with a right-hand side that projects to zero returns x = 0 in no iteration", "[solve][pcg]") {
  // b is nonzero at the fixed DOFs only: P b = 0, so |b| = 0 and the solve stops as it starts,
  // whether its scalars are read every iteration or now and then, and whatever its settings.
  const int n = 12;
  const DenseOperator A = three_eigenvalue_matrix(n);
  std::vector<std::uint8_t> fixed(n, 0);
  std::vector<double> b(n, 0.0);
  for (int k : {2, 7}) fixed[k] = 1, b[k] = 3.0;
  for (const bool fixed_iterations : {false, true}) {
    CAPTURE(fixed_iterations);
    PcgSettings settings;
    settings.fixed_iterations = fixed_iterations;
    settings.max_iterations = fixed_iterations ? 60 : 2000;
    const HostVectorOps every(n, fixed.data());
    const DeferredReadOps deferred(n, fixed.data());
    std::vector<double> x_every(n, 5.0), x_deferred(n, 5.0);
    const LinearResult a = pcg(every, A, IdentityPreconditioner<HostVectorOps>{every}, settings, b, x_every);
    const LinearResult d =
        pcg(deferred, A, IdentityPreconditioner<DeferredReadOps>{deferred}, settings, b, x_deferred);
    for (const LinearResult* r : {&a, &d}) {
      CHECK(r->converged);
      CHECK(r->iterations == 0);
      CHECK(r->relative_residual == 0.0);
      CHECK_FALSE(r->negative_curvature);
    }
    // Preconditioned (z = 2 r, its own vector): the same.
    std::vector<double> x_preconditioned(n, 5.0);
    auto twice = [](const std::vector<double>& r, std::vector<double>& z) {
      for (std::size_t k = 0; k < r.size(); ++k) z[k] = 2 * r[k];
    };
    const LinearResult p = pcg(every, A, twice, settings, b, x_preconditioned);
    CHECK(p.converged);
    CHECK(p.iterations == 0);
    CHECK(p.relative_residual == 0.0);
    CHECK(x_every == std::vector<double>(n, 0.0));
    CHECK(x_deferred == std::vector<double>(n, 0.0));
    CHECK(x_preconditioned == std::vector<double>(n, 0.0));
  }
}
