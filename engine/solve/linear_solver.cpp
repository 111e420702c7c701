#include "solve/linear_solver.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/Dense>

#include <cmath>
#include <stdexcept>

namespace fascia {
namespace {

void project(const std::uint8_t* fixed, std::vector<double>& v) {
  if (!fixed) return;
  for (size_t k = 0; k < v.size(); ++k)
    if (fixed[k]) v[k] = 0;
}

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t k = 0; k < a.size(); ++k) s += a[k] * b[k];
  return s;
}

// Inverse 6x6 diagonal blocks; fixed DOFs get identity rows/columns. A block that is not
// positive definite (possible away from equilibrium: geometric stiffness) is replaced by the
// inverse of its absolute diagonal, which keeps the preconditioner symmetric positive definite.
std::vector<double> block_jacobi(const LinearSystem& system) {
  const int frames = system.size / 6;
  std::vector<double> blocks(36 * frames);
  system.diagonal_blocks(blocks.data());
  for (int i = 0; i < frames; ++i) {
    Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>> B(&blocks[36 * i]);
    double largest = 0;
    for (int k = 0; k < 6; ++k) largest = std::max(largest, std::abs(B(k, k)));
    if (largest == 0) largest = 1;
    for (int k = 0; k < 6; ++k)
      if (system.fixed && system.fixed[6 * i + k]) {
        B.row(k).setZero();
        B.col(k).setZero();
        B(k, k) = largest;
      }
    Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(B);
    if (llt.info() == Eigen::Success) {
      B = llt.solve(Eigen::Matrix<double, 6, 6>::Identity());
    } else {
      Eigen::Matrix<double, 6, 6> D = Eigen::Matrix<double, 6, 6>::Zero();
      for (int k = 0; k < 6; ++k) D(k, k) = 1.0 / std::max(std::abs(B(k, k)), 1e-12 * largest);
      B = D;
    }
  }
  return blocks;
}

// Preconditioned conjugate gradients on the free DOFs (Saad, Iterative Methods, Alg. 9.1).
// Stops at |r|_2 <= tol |b|_2, or after exactly max_iterations when fixed_iterations; on
// non-positive curvature returns the current iterate (or b's preconditioned direction when no
// step was taken), which is still a descent direction for Newton (Steihaug truncation).
LinearResult conjugate_gradient(const LinearSystem& system, const LinearSettings& settings,
                                const std::vector<double>* preconditioner, const std::vector<double>& b_in,
                                std::vector<double>& x) {
  const int n = system.size;
  std::vector<double> b = b_in;
  project(system.fixed, b);
  x.assign(n, 0.0);
  std::vector<double> r = b, z(preconditioner ? n : 0), p(n), hp(n);
  // Without a preconditioner z = r: refer to r instead of copying it every iteration.
  const std::vector<double>& zr = preconditioner ? z : r;
  auto precondition = [&](const std::vector<double>& in, std::vector<double>& out) {
    if (!preconditioner) return;
    for (int i = 0; i < n / 6; ++i)
      for (int a = 0; a < 6; ++a) {
        double s = 0;
        for (int c = 0; c < 6; ++c) s += (*preconditioner)[36 * i + 6 * a + c] * in[6 * i + c];
        out[6 * i + a] = s;
      }
    project(system.fixed, out);
  };
  LinearResult result;
  const double b_norm = std::sqrt(dot(b, b));
  if (b_norm == 0) {
    result.converged = true;
    return result;
  }
  precondition(r, z);
  p = zr;
  double rz = dot(r, zr);
  for (int k = 0; k < settings.max_iterations; ++k) {
    system.apply(p.data(), hp.data());
    // p^T H p, with H p projected onto the free DOFs. The loops below are SIMD reductions: a
    // fixed summation order for a given build, independent of the thread count.
    double curvature = 0;
    double* __restrict hpd = hp.data();
    const double* __restrict pd = p.data();
    if (system.fixed) {
      const std::uint8_t* __restrict fixed = system.fixed;
#pragma omp simd reduction(+ : curvature)
      for (int j = 0; j < n; ++j) {
        hpd[j] = fixed[j] ? 0.0 : hpd[j];
        curvature += pd[j] * hpd[j];
      }
    } else {
#pragma omp simd reduction(+ : curvature)
      for (int j = 0; j < n; ++j) curvature += pd[j] * hpd[j];
    }
    if (!(curvature > 0)) {
      result.negative_curvature = true;
      if (k == 0) x = zr;  // preconditioned steepest descent
      result.iterations = k;
      result.relative_residual = std::sqrt(dot(r, r)) / b_norm;
      result.message = "non-positive curvature in CG; step truncated";
      return result;
    }
    const double alpha = rz / curvature;
    double rr = 0;
    double* __restrict xd = x.data();
    double* __restrict rd = r.data();
#pragma omp simd reduction(+ : rr)
    for (int j = 0; j < n; ++j) {
      xd[j] += alpha * pd[j];
      rd[j] -= alpha * hpd[j];
      rr += rd[j] * rd[j];
    }
    result.iterations = k + 1;
    result.relative_residual = std::sqrt(rr) / b_norm;
    if (!settings.fixed_iterations && result.relative_residual <= settings.tolerance) {
      result.converged = true;
      return result;
    }
    precondition(r, z);
    const double rz_new = preconditioner ? dot(r, z) : rr;
    const double beta = rz_new / rz;
    rz = rz_new;
    const double* __restrict zd = zr.data();
    double* __restrict pw = p.data();
#pragma omp simd
    for (int j = 0; j < n; ++j) pw[j] = zd[j] + beta * pw[j];
  }
  result.converged = result.relative_residual <= settings.tolerance || settings.fixed_iterations;
  if (!result.converged) result.message = "CG reached its iteration cap";
  return result;
}

LinearResult cholmod_solve(const LinearSystem& system, const std::vector<double>& b,
                           std::vector<double>& x) {
  const int n = system.size;
  std::vector<int> index(n, -1);
  int free = 0;
  for (int k = 0; k < n; ++k)
    if (!(system.fixed && system.fixed[k])) index[k] = free++;
  const Eigen::SparseMatrix<double> H = system.assemble();
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(H.nonZeros());
  for (int c = 0; c < H.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(H, c); it; ++it)
      if (index[it.row()] >= 0 && index[it.col()] >= 0 && index[it.row()] >= index[it.col()])
        t.emplace_back(index[it.row()], index[it.col()], it.value());
  Eigen::SparseMatrix<double> reduced(free, free);
  reduced.setFromTriplets(t.begin(), t.end());
  Eigen::VectorXd rhs(free);
  for (int k = 0; k < n; ++k)
    if (index[k] >= 0) rhs[index[k]] = b[k];
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Lower> llt;
  llt.cholmod().print = 0;  // failures are reported through LinearResult, not on stderr
  llt.analyzePattern(reduced);
  llt.factorize(reduced);
  // Not positive definite (away from equilibrium the geometric stiffness can make H indefinite):
  // modified Newton, H + tau diag(|H_kk|), tau = 1e-6, 1e-5, ... until the factorisation
  // succeeds; the result is still a descent direction.
  double tau = 0;
  Eigen::VectorXd diag = reduced.diagonal().cwiseAbs();
  const double mean_diag = diag.size() ? diag.mean() : 1.0;
  for (int k = 0; k < diag.size(); ++k) diag[k] = std::max(diag[k], 1e-12 * mean_diag);
  for (tau = 1e-6; llt.info() != Eigen::Success && tau <= 1e3; tau *= 10) {
    Eigen::SparseMatrix<double> shifted = reduced;
    for (int k = 0; k < free; ++k) shifted.coeffRef(k, k) += tau * diag[k];
    llt.factorize(shifted);
  }
  if (llt.info() != Eigen::Success) {
    LinearResult r;
    r.message = "CHOLMOD: tangent could not be factorised even with a diagonal shift";
    return r;
  }
  const Eigen::VectorXd sol = llt.solve(rhs);
  x.assign(n, 0.0);
  for (int k = 0; k < n; ++k)
    if (index[k] >= 0) x[k] = sol[index[k]];
  LinearResult r;
  r.converged = true;
  r.iterations = 0;
  if (tau > 1e-6) {
    r.fell_back = true;
    r.message = "CHOLMOD: tangent not positive definite, shifted by " + std::to_string(tau / 10) + " diag(H)";
  }
  std::vector<double> hx(n);
  system.apply(x.data(), hx.data());
  project(system.fixed, hx);
  double num = 0, den = 0;
  for (int k = 0; k < n; ++k)
    if (index[k] >= 0) num += (hx[k] - b[k]) * (hx[k] - b[k]), den += b[k] * b[k];
  r.relative_residual = den > 0 ? std::sqrt(num / den) : 0;
  return r;
}

}  // namespace

const char* to_string(LinearMethod method) {
  switch (method) {
    case LinearMethod::cg: return "cg";
    case LinearMethod::pcg: return "pcg";
    case LinearMethod::cholmod: return "cholmod";
  }
  return "?";
}

LinearMethod parse_linear_method(const std::string& name) {
  if (name == "cg") return LinearMethod::cg;
  if (name == "pcg") return LinearMethod::pcg;
  if (name == "cholmod") return LinearMethod::cholmod;
  throw std::invalid_argument("unknown linear method '" + name + "' (expected cg, pcg or cholmod)");
}

LinearResult solve_linear(const LinearSystem& system, const LinearSettings& settings, const std::vector<double>& b,
                          std::vector<double>& x) {
  switch (settings.method) {
    case LinearMethod::cg: return conjugate_gradient(system, settings, nullptr, b, x);
    case LinearMethod::pcg: {
      const std::vector<double> pre = block_jacobi(system);
      return conjugate_gradient(system, settings, &pre, b, x);
    }
    case LinearMethod::cholmod: return cholmod_solve(system, b, x);
  }
  throw std::logic_error("unreachable");
}

}  // namespace fascia
