// Flexible GMRES on the free degrees of freedom, written once over a backend's vector operations
// (solve/vector_ops.hpp), for the non-symmetric systems of Newton's residual problems
// (solve/newton.hpp: the Newton-Krylov direction).
//
// Solves A x = b for a general A restricted to the free DOFs, right-preconditioned by a
// preconditioner that may change from one iteration to the next (an inner iterative solve):
// Saad, "A flexible inner-outer preconditioned GMRES algorithm", SIAM J. Sci. Comput. 14 (1993),
// and Iterative Methods for Sparse Linear Systems, 2nd ed., Alg. 9.6. With z_j = M_j^{-1} v_j and
// A z_j orthogonalised against v_1 .. v_j (modified Gram-Schmidt), A Z_k = V_{k+1} Hbar_k; the
// iterate x_k = Z_k y_k minimises |b - A x| over span(Z_k), and Givens rotations of Hbar_k give
// that residual norm at every iteration without forming x. No restart: at most max_iterations
// vectors of each kind are kept (a Newton direction needs a few). b, every z_j and A z_j are
// projected, so fixed DOFs stay zero. Stops at |b - A x| <= tolerance |b|, after max_iterations,
// at a breakdown (h_{k+1,k} = 0: x_k solves the system), or where A z_k = 0 (z_k adds nothing,
// a singular A); a product that cannot be formed stops it with x = 0 and product_failed.
#pragma once

#include "core/stop_request.hpp"
#include "solve/linear_result.hpp"

#include <cmath>
#include <vector>

namespace fascia {

struct FgmresSettings {
  double tolerance = 1e-8;  // relative residual |b - A x| / |b| to stop at
  int max_iterations = 20;  // Krylov vectors kept (no restart)
};

// @param apply          callable (const Vector& z, Vector& out) -> bool: out = A z (projection not
//                       needed); false where A z cannot be formed (the solve stops)
// @param precondition   callable (const Vector& v, Vector& z) -> int: z ~ A^{-1} v, the inner
//                       iterations it took (counted in the result's iterations)
// @param b              right-hand side [n]; projected here
// @param x              solution [n], resized
// Returns: iterations = the inner iterations, relative_residual = |b - A x| / |b| (from the
// rotations: exact in exact arithmetic).
template <class Ops, class Apply, class Precondition>
LinearResult fgmres(const Ops& ops, Apply&& apply, Precondition&& precondition, const FgmresSettings& settings,
                    const typename Ops::Vector& b, typename Ops::Vector& x) {
  using Vector = typename Ops::Vector;
  const int m = settings.max_iterations;
  LinearResult result;
  ops.fill(x, 0.0);
  std::vector<Vector> v(static_cast<size_t>(m) + 1), z(static_cast<size_t>(m));
  ops.copy(b, v[0]);
  ops.project(v[0]);
  const double beta = ops.norm(v[0]);
  if (beta == 0) {
    result.converged = true;
    return result;
  }
  ops.scale(1 / beta, v[0]);
  // Hbar (column-major, (m + 1) x m), the rotations (c, s) and the rotated right-hand side g.
  std::vector<double> h(static_cast<size_t>(m + 1) * m, 0.0), c(m, 0.0), s(m, 0.0), g(m + 1, 0.0);
  auto H = [&](int i, int j) -> double& { return h[static_cast<size_t>(j) * (m + 1) + i]; };
  g[0] = beta;
  double residual = beta;
  int k = 0;
  while (k < m && residual > settings.tolerance * beta) {
    throw_if_stop_requested();
    ops.resize(z[k]);
    result.iterations += precondition(v[k], z[k]);
    ops.project(z[k]);
    Vector& w = v[k + 1];
    ops.resize(w);
    if (!apply(z[k], w)) {
      ops.fill(x, 0.0);
      result.relative_residual = 1;
      result.product_failed = true;
      result.message = "GMRES: the operator's product could not be formed";
      return result;
    }
    ops.project(w);
    for (int i = 0; i <= k; ++i) {
      H(i, k) = ops.dot(w, v[i]);
      ops.axpy(-H(i, k), v[i], w);
    }
    H(k + 1, k) = ops.norm(w);
    for (int i = 0; i < k; ++i) {  // the earlier rotations on the new column
      const double a = H(i, k), b2 = H(i + 1, k);
      H(i, k) = c[i] * a + s[i] * b2;
      H(i + 1, k) = -s[i] * a + c[i] * b2;
    }
    const double r = std::hypot(H(k, k), H(k + 1, k));
    if (!(r > 0)) {  // A z_k = 0 on the free DOFs: z_k adds nothing, the residual stays
      H(k, k) = 0;
      ++k;
      break;
    }
    const bool breakdown = !(H(k + 1, k) > 0);
    c[k] = H(k, k) / r;
    s[k] = H(k + 1, k) / r;
    if (!breakdown) ops.scale(1 / H(k + 1, k), w);
    H(k, k) = r;
    H(k + 1, k) = 0;
    g[k + 1] = -s[k] * g[k];
    g[k] = c[k] * g[k];
    residual = std::abs(g[k + 1]);
    ++k;
    if (breakdown || !std::isfinite(residual)) break;
  }
  // y = R_k^{-1} g (upper triangular), x = Z_k y; a zero pivot (A z_j = 0) drops its direction.
  std::vector<double> y(k, 0.0);
  for (int i = k - 1; i >= 0; --i) {
    double sum = g[i];
    for (int j = i + 1; j < k; ++j) sum -= H(i, j) * y[j];
    y[i] = H(i, i) != 0 ? sum / H(i, i) : 0.0;
  }
  for (int j = 0; j < k; ++j) ops.axpy(y[j], z[j], x);
  result.relative_residual = residual / beta;
  result.converged = result.relative_residual <= settings.tolerance;
  if (!std::isfinite(result.relative_residual)) {
    ops.fill(x, 0.0);
    result.converged = false;
    result.message = "GMRES: non-finite residual";
  } else if (!result.converged) {
    result.message = "GMRES reached its iteration cap";
  }
  return result;
}

}  // namespace fascia
