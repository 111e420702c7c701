// The sparse Cholesky factorisation of the free-free block: solves against a dense reference,
// keeps its symbolic analysis for patterns inside the analysed one, refactorises a matrix of the
// last pattern as a fresh factorisation would, shifts indefinite matrices (from a decade below
// the last shift), preconditions with a large factor's values in float,
// and leaves the caller's OpenMP team size and nesting limit unchanged.
#include "solve/sparse_cholesky.hpp"
#include "solve/diagonal_shifts.hpp"

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <omp.h>

#include <cmath>
#include <stdexcept>
#include <vector>

using namespace fascia;

namespace {

// A tridiagonal SPD matrix (diagonal 4, off-diagonal -1: diagonally dominant) of size n, plus
// an optional extra symmetric pair (a, b) of value v.
Eigen::SparseMatrix<double> tridiagonal(int n, int a = -1, int b = -1, double v = 0) {
  std::vector<Eigen::Triplet<double>> t;
  for (int k = 0; k < n; ++k) {
    t.emplace_back(k, k, 4.0);
    if (k + 1 < n) t.emplace_back(k + 1, k, -1.0), t.emplace_back(k, k + 1, -1.0);
  }
  if (a >= 0) t.emplace_back(a, b, v), t.emplace_back(b, a, v);
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

// max |x - H_ff^{-1} b_f| over the free DOFs, x = 0 at fixed ones (dense reference).
double solve_error(const SparseCholesky& chol, const Eigen::SparseMatrix<double>& H, const std::vector<std::uint8_t>& fixed) {
  const int n = static_cast<int>(H.rows());
  std::vector<int> free;
  for (int k = 0; k < n; ++k)
    if (!fixed[k]) free.push_back(k);
  const Eigen::MatrixXd dense = Eigen::MatrixXd(H);
  Eigen::MatrixXd hff(free.size(), free.size());
  Eigen::VectorXd bf(free.size());
  std::vector<double> b(n), x;
  for (int k = 0; k < n; ++k) b[k] = std::sin(1.0 + k);
  for (size_t r = 0; r < free.size(); ++r) {
    bf[r] = b[free[r]];
    for (size_t c = 0; c < free.size(); ++c) hff(r, c) = dense(free[r], free[c]);
  }
  const Eigen::VectorXd ref = hff.llt().solve(bf);
  chol.solve(b, x);
  double err = 0;
  for (int k = 0; k < n; ++k)
    if (fixed[k]) err = std::max(err, std::abs(x[k]));
  for (size_t r = 0; r < free.size(); ++r) err = std::max(err, std::abs(x[free[r]] - ref[r]));
  return err;
}

// Frames on a side x side grid, 6 DOFs each, coupled to their 4 neighbours by dense 6 x 6
// blocks of entries in [-0.1, 0.1], with 6 + (k mod 5) on the diagonal: every row's
// off-diagonal entries sum to at most 4 * 6 * 0.1 = 2.4 < 6, so cond <= (11 + 2.4) / (6 - 2.4)
// < 4 (Gershgorin). A fill-reducing ordering of a 2D grid leaves dense separators: CHOLMOD
// factorises it supernodally.
Eigen::SparseMatrix<double> block_grid(int side) {
  const int frames = side * side, n = 6 * frames;
  std::vector<Eigen::Triplet<double>> t;
  for (int k = 0; k < n; ++k) t.emplace_back(k, k, 6.0 + k % 5);
  auto couple = [&](int a, int b) {
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) {
        const double v = 0.1 * std::sin(1.0 + 7 * a + 3 * b + 6 * i + j);
        t.emplace_back(6 * a + i, 6 * b + j, v);
        t.emplace_back(6 * b + j, 6 * a + i, v);
      }
  };
  for (int r = 0; r < side; ++r)
    for (int c = 0; c < side; ++c) {
      if (c + 1 < side) couple(r * side + c, r * side + c + 1);
      if (r + 1 < side) couple(r * side + c, (r + 1) * side + c);
    }
  Eigen::SparseMatrix<double> m(n, n);
  m.setFromTriplets(t.begin(), t.end());
  return m;
}

}  // namespace

TEST_CASE("a supernodal factor solves as a dense Cholesky does", "[solve]") {
  const Eigen::SparseMatrix<double> H = block_grid(12);
  std::vector<std::uint8_t> fixed(H.rows(), 0);
  for (int k = 0; k < 6; ++k) fixed[k] = fixed[300 + k] = 1;
  fixed[151] = 1;  // a frame of 5 free DOFs: supernodes whose width is not a multiple of 4 or 6
  SparseCholesky chol;
  REQUIRE(chol.factorise(H, fixed.data()));
  REQUIRE(chol.supernodal());
  // cond < 4: accurate to a few eps of |x| (about 0.3 here); 1e-13.
  CHECK(solve_error(chol, H, fixed) <= 1e-13);
}

TEST_CASE("a large factor preconditions with its values in float and solves with its own", "[solve]") {
  // block_grid(64): 24,576 DOFs, a factor of more than 1e6 stored entries. Rounding L's values to
  // float changes each by at most 2^-24 of itself, so L L^T by about 1e-7 of |H| (its rows have
  // tens of entries) and the solution, cond < 4, by about 1e-6 of |x| at most. A direct solve
  // reads the factor's own values; so does a small factor's preconditioning (block_grid(12)).
  const Eigen::SparseMatrix<double> H = block_grid(64), S = block_grid(12);
  const int n = static_cast<int>(H.rows()), m = static_cast<int>(S.rows());
  const std::vector<std::uint8_t> fixed(n, 0), small_fixed(m, 0);
  SparseCholesky chol, small;
  REQUIRE(chol.factorise(H, fixed.data()));
  REQUIRE(small.factorise(S, small_fixed.data()));
  REQUIRE(chol.supernodal());
  std::vector<double> b(n), exact, single, again;
  for (int k = 0; k < n; ++k) b[k] = std::sin(1.0 + k);
  chol.solve(b, exact);
  chol.solve(b, single, true);
  chol.solve(b, again, true);
  double difference = 0, size = 0;
  for (int k = 0; k < n; ++k) {
    difference = std::max(difference, std::abs(single[k] - exact[k]));
    size = std::max(size, std::abs(exact[k]));
  }
  CHECK(single != exact);   // the float values were read
  CHECK(single == again);   // the same copy, the same bits
  CHECK(difference <= 1e-6 * size);
  CHECK(difference >= 1e-12 * size);
  const Eigen::Map<const Eigen::VectorXd> x(exact.data(), n), bv(b.data(), n);
  CHECK((H * x - bv).norm() <= 1e-12 * bv.norm());  // the direct solve: backward stable, cond < 4
  // A new factorisation's sweeps read its own values in float: of 2 H, half the solution (within
  // the same bound), not the last copy's.
  const Eigen::SparseMatrix<double> H2 = 2.0 * H;
  REQUIRE(chol.factorise(H2, fixed.data()));
  std::vector<double> halved;
  chol.solve(b, halved, true);
  double difference2 = 0;
  for (int k = 0; k < n; ++k) difference2 = std::max(difference2, std::abs(halved[k] - 0.5 * exact[k]));
  CHECK(difference2 <= 1e-6 * size);
  std::vector<double> bs(b.begin(), b.begin() + m), small_exact, small_single;
  small.solve(bs, small_exact);
  small.solve(bs, small_single, true);
  CHECK(small_single == small_exact);
}

TEST_CASE("the factorisation keeps its analysis while the pattern stays inside the analysed one", "[solve]") {
  const int n = 30;
  std::vector<std::uint8_t> fixed(n, 0);
  fixed[0] = fixed[17] = 1;
  SparseCholesky chol;
  // cond <= (4 + 2) / (4 - 2) = 3 (Gershgorin), so the solve is accurate to a few eps; 1e-13.
  const Eigen::SparseMatrix<double> with_pair = tridiagonal(n, 20, 5, -0.5);
  REQUIRE(chol.factorise(with_pair, fixed.data()));
  REQUIRE(solve_error(chol, with_pair, fixed) <= 1e-13);
  // The same pattern without the (20, 5) pair, as an assembly that skips a zero entry.
  const Eigen::SparseMatrix<double> without = tridiagonal(n);
  REQUIRE(chol.factorise(without, fixed.data()));
  REQUIRE(solve_error(chol, without, fixed) <= 1e-13);
  REQUIRE(chol.analyses() == 1);
  // An entry outside the analysed pattern needs a new analysis.
  const Eigen::SparseMatrix<double> other = tridiagonal(n, 25, 2, -0.5);
  REQUIRE(chol.factorise(other, fixed.data()));
  REQUIRE(solve_error(chol, other, fixed) <= 1e-13);
  REQUIRE(chol.analyses() == 2);
  REQUIRE(chol.factorisations() == 3);
  REQUIRE(chol.shift() == 0);
}

TEST_CASE("a matrix of the last matrix's pattern is factorised as a fresh factorisation would", "[solve]") {
  // The second matrix has the first's pattern (the (20, 5) pair held at zero) and other values:
  // its entries go straight to the positions found for the first. A fresh factorisation of it
  // (a new object: the triplet path) must give the same bits.
  const int n = 30;
  std::vector<std::uint8_t> fixed(n, 0);
  fixed[3] = fixed[11] = 1;
  const Eigen::SparseMatrix<double> first = tridiagonal(n, 20, 5, -0.5);
  Eigen::SparseMatrix<double> second = tridiagonal(n, 20, 5, 0.0);
  REQUIRE(second.nonZeros() == first.nonZeros());
  for (int k = 0; k < second.nonZeros(); ++k) second.valuePtr()[k] *= 1 + 0.01 * std::cos(k);
  SparseCholesky reused, fresh;
  REQUIRE(reused.factorise(first, fixed.data()));
  REQUIRE(reused.factorise(second, fixed.data()));
  REQUIRE(fresh.factorise(second, fixed.data()));
  REQUIRE(reused.analyses() == 1);
  REQUIRE(reused.pattern_fingerprint() == fresh.pattern_fingerprint());
  std::vector<double> b(n), x_reused, x_fresh;
  for (int k = 0; k < n; ++k) b[k] = std::sin(2.0 + k);
  reused.solve(b, x_reused);
  fresh.solve(b, x_fresh);
  REQUIRE(x_reused == x_fresh);
  REQUIRE(solve_error(reused, second, fixed) <= 1e-13);
}

TEST_CASE("an indefinite matrix is factorised with a diagonal shift", "[solve]") {
  Eigen::SparseMatrix<double> H = tridiagonal(6);
  H.coeffRef(3, 3) = -1.0;
  SparseCholesky chol;
  REQUIRE(chol.factorise(H, nullptr));
  REQUIRE(chol.shift() > 0);
}

TEST_CASE("after an unshifted try the first shift tried is a decade below the last factorisation's", "[solve]") {
  Eigen::SparseMatrix<double> H = tridiagonal(6);
  H.coeffRef(3, 3) = -1.0;  // a shift of at least 1 |H_33| = 1 is needed
  SparseCholesky chol;
  REQUIRE(chol.factorise(H, nullptr));
  const int k = chol.shift_step();
  REQUIRE(k >= 6);
  CHECK(chol.shift() == std::pow(10.0, k - 6));
  CHECK(chol.first_shift_step() == k - 1);
  // The same matrix again: unshifted and the decade below fail, the last one serves.
  REQUIRE(chol.factorise(H, nullptr));
  CHECK(chol.shift_step() == k);
  CHECK(chol.factorisations() == 2);
  // A positive definite matrix is factorised unshifted; the next search starts at the smallest.
  const Eigen::SparseMatrix<double> spd = tridiagonal(6);
  REQUIRE(chol.factorise(spd, nullptr));
  CHECK(chol.shift_step() == -1);
  CHECK(chol.shift() == 0);
  CHECK(chol.first_shift_step() == 0);
  // A factorisation told to start where another's shift was (a resumed run) repeats it bit for
  // bit, whatever it would find from no shift.
  REQUIRE(chol.factorise(H, nullptr));
  REQUIRE(chol.shift_step() == k);
  SparseCholesky resumed;
  resumed.set_first_shift_step(k);
  REQUIRE(resumed.factorise(H, nullptr));
  CHECK(resumed.shift_step() == k);
  std::vector<double> b(6), x, y;
  for (int i = 0; i < 6; ++i) b[i] = std::cos(1.0 + i);
  chol.solve(b, x);
  resumed.solve(b, y);
  CHECK(x == y);
  // Whatever the last shift, the search finds the smallest one that succeeds, as a fresh
  // factorisation's does: down from the last one (H_33 = 0.25 and 0.2 need smaller shifts than
  // -1) and up (-1 after them), and none for a positive definite matrix.
  SparseCholesky kept;
  for (const double h33 : {-1.0, 0.25, 0.2, -1.0, 0.26, 4.0, -1.0, 0.2}) {
    Eigen::SparseMatrix<double> M = tridiagonal(6);
    M.coeffRef(3, 3) = h33;
    SparseCholesky fresh;
    REQUIRE(kept.factorise(M, nullptr));
    REQUIRE(fresh.factorise(M, nullptr));
    INFO("H_33 = " << h33);
    CHECK(kept.shift_step() == fresh.shift_step());
    kept.solve(b, x);
    fresh.solve(b, y);
    CHECK(x == y);
  }
  CHECK_THROWS_AS(resumed.set_first_shift_step(kShiftSteps), std::invalid_argument);
  CHECK_THROWS_AS(resumed.set_first_shift_step(-1), std::invalid_argument);
}

TEST_CASE("a solve leaves the caller's OpenMP team size as it found it", "[solve]") {
  // Small factors are solved with a team of one (the solve's own setting); the caller's next
  // parallel regions keep the size it chose.
  const int n = 40;
  const std::vector<std::uint8_t> fixed(n, 0);
  SparseCholesky chol;
  const Eigen::SparseMatrix<double> H = tridiagonal(n);
  REQUIRE(chol.factorise(H, fixed.data()));
  const int before = omp_get_max_threads();
  omp_set_num_threads(3);
  const double error = solve_error(chol, H, fixed);
  const int after = omp_get_max_threads();
  omp_set_num_threads(before);
  REQUIRE(after == 3);
  REQUIRE(error <= 1e-13);  // cond <= 3 as above
}

TEST_CASE("a factorisation leaves the caller's OpenMP team size and nesting limit as it found them", "[solve]") {
  // Small factors are factorised with every OpenMP region inactive (one thread, whatever a
  // region's num_threads clause asks); the caller's settings come back afterwards.
  const int n = 40;
  const std::vector<std::uint8_t> fixed(n, 0);
  const int threads_before = omp_get_max_threads(), levels_before = omp_get_max_active_levels();
  omp_set_num_threads(3);
  omp_set_max_active_levels(2);
  SparseCholesky chol;
  const Eigen::SparseMatrix<double> H = tridiagonal(n);
  const bool factorised = chol.factorise(H, fixed.data());
  const int threads_after = omp_get_max_threads(), levels_after = omp_get_max_active_levels();
  omp_set_num_threads(threads_before);
  omp_set_max_active_levels(levels_before);
  REQUIRE(factorised);
  CHECK(threads_after == 3);
  CHECK(levels_after == 2);
  CHECK(solve_error(chol, H, fixed) <= 1e-13);  // cond <= 3 as above
}
