// The selection of OpenBLAS's kernels: which core replaces the generic fallback, a switch of
// kernels that factorises and solves as before it and restores the caller's OPENBLAS_CORETYPE,
// and a user's OPENBLAS_CORETYPE left in charge.
#include "solve/blas_core.hpp"
#include "solve/sparse_cholesky.hpp"

#include <Eigen/Dense>
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

using namespace fascia;

namespace {

// A dense SPD matrix of order n (diagonal n + 1, off-diagonal entries in (-1, 1): diagonally
// dominant, condition number below (2n + 1) / 1 = 2n + 1): dense enough that CHOLMOD factorises
// it supernodally, through the BLAS.
Eigen::MatrixXd dense_spd(int n) {
  Eigen::MatrixXd a(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j <= i; ++j) a(i, j) = a(j, i) = i == j ? n + 1.0 : std::sin(1.0 + 7.0 * i + 3.0 * j);
  return a;
}

// max |x - A^{-1} b| / max |A^{-1} b| of SparseCholesky's solve against Eigen's dense LLT.
double solve_error(const Eigen::MatrixXd& a) {
  const int n = static_cast<int>(a.rows());
  SparseCholesky chol;
  REQUIRE(chol.factorise(a.sparseView(), nullptr));
  std::vector<double> b(static_cast<size_t>(n)), x;
  for (int k = 0; k < n; ++k) b[static_cast<size_t>(k)] = std::cos(0.3 * k);
  chol.solve(b, x);
  const Eigen::VectorXd ref = a.llt().solve(Eigen::Map<const Eigen::VectorXd>(b.data(), n));
  const Eigen::VectorXd error = Eigen::Map<const Eigen::VectorXd>(x.data(), n) - ref;
  return error.lpNorm<Eigen::Infinity>() / ref.lpNorm<Eigen::Infinity>();
}

// OPENBLAS_CORETYPE as the process has it (nullopt: unset).
std::optional<std::string> coretype_variable() {
  const char* value = std::getenv("OPENBLAS_CORETYPE");
  return value ? std::optional<std::string>(value) : std::nullopt;
}

// Puts OPENBLAS_CORETYPE back as the test run found it (a user may have set it) at scope exit.
struct CoretypeRestore {
  std::optional<std::string> saved = coretype_variable();
  ~CoretypeRestore() {
    if (saved)
      setenv("OPENBLAS_CORETYPE", saved->c_str(), 1);
    else
      unsetenv("OPENBLAS_CORETYPE");
  }
};

}  // namespace

TEST_CASE("blas core: the generic fallback gives way to the kernels the CPU supports", "[solve][blas]") {
  CHECK(better_blas_core("Prescott", true, true) == "SkylakeX");
  CHECK(better_blas_core("Prescott", false, true) == "Haswell");
  CHECK(better_blas_core("Prescott", false, false).empty());
  // A core OpenBLAS recognised stays.
  CHECK(better_blas_core("Cooperlake", true, true).empty());
  CHECK(better_blas_core("Haswell", true, true).empty());
  CHECK(better_blas_core("", true, true).empty());
}

TEST_CASE("blas core: a switch of kernels solves as before and restores OPENBLAS_CORETYPE", "[solve][blas]") {
  const std::string original = blas_core();
  const std::optional<std::string> variable = coretype_variable();  // a user's, or unset
  // Backward-stable Cholesky: relative error below about n u cond(A) = 300 * 1.1e-16 * 601 = 2e-11.
  const Eigen::MatrixXd a = dense_spd(300);
  const double before = solve_error(a);
  CHECK(before < 2e-11);
  if (original.empty()) {
    // Another BLAS than OpenBLAS: nothing to select.
    CHECK_FALSE(set_blas_core("Prescott"));
    CHECK(select_blas_core().empty());
    return;
  }
  // Prescott's SSE3 kernels run on every x86-64 CPU.
  REQUIRE(set_blas_core("Prescott"));
  CHECK(blas_core() == "Prescott");
  CHECK(coretype_variable() == variable);
  CHECK(solve_error(a) < 2e-11);
  REQUIRE(set_blas_core(original));
  CHECK(blas_core() == original);
  CHECK(solve_error(a) == before);
}

TEST_CASE("blas core: a user's OPENBLAS_CORETYPE is left in charge", "[solve][blas]") {
  const CoretypeRestore restore;
  const std::string original = blas_core();
  setenv("OPENBLAS_CORETYPE", "Prescott", 1);
  CHECK(select_blas_core().empty());
  CHECK(blas_core() == original);
}
