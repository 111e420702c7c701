// Preconditioned conjugate gradients on the free degrees of freedom, written once over a
// backend's vector operations (solve/vector_ops.hpp): the CPU runs it with HostVectorOps, a
// device backend with its own Ops.
//
// Solves H x = b for symmetric H restricted to the free DOFs (Saad, Iterative Methods for Sparse
// Linear Systems, 2nd ed., Alg. 9.1): b, H p and every iterate are projected, so fixed DOFs stay
// zero. Stops at |r|_2 <= tolerance |b|_2 (the unpreconditioned residual, the same test whatever
// the preconditioner), or after exactly max_iterations when fixed_iterations (the paper's
// benchmarks). On non-positive curvature p^T H p <= 0 it returns the current iterate, or the
// preconditioned residual when no step was taken: still a descent direction for Newton
// (Steihaug's truncation; Nocedal & Wright, Numerical Optimization, Alg. 7.2).
#pragma once

#include "core/stop_request.hpp"
#include "solve/linear_result.hpp"

#include <cmath>

namespace fascia {

struct PcgSettings {
  double tolerance = 1e-8;        // relative residual |r| / |b| to stop at
  int max_iterations = 2000;
  bool fixed_iterations = false;  // run exactly max_iterations
};

// @param apply          callable (const Vector& p, Vector& out): out = H p (projection not needed)
// @param precondition   callable (const Vector& r, Vector& z): z = M^{-1} r, M symmetric positive
//                       definite on the free DOFs (z is projected afterwards)
// @param b              right-hand side [n]; projected here
// @param x              solution [n], resized; starts from zero
template <class Ops, class Apply, class Precondition>
LinearResult pcg(const Ops& ops, Apply&& apply, Precondition&& precondition, const PcgSettings& settings,
                 const typename Ops::Vector& b_in, typename Ops::Vector& x) {
  using Vector = typename Ops::Vector;
  Vector b, r, z, p, hp;
  ops.copy(b_in, b);
  ops.project(b);
  ops.fill(x, 0.0);
  ops.copy(b, r);
  ops.resize(z);
  ops.resize(hp);
  LinearResult result;
  const double b_norm = ops.norm(b);
  if (b_norm == 0) {
    result.converged = true;
    return result;
  }
  precondition(r, z);
  ops.project(z);
  ops.copy(z, p);
  double rz = ops.dot(r, z);
  for (int k = 0; k < settings.max_iterations; ++k) {
    throw_if_stop_requested();  // a stop takes effect within one product
    apply(p, hp);
    ops.project(hp);
    const double curvature = ops.dot(p, hp);
    if (!(curvature > 0)) {
      result.negative_curvature = true;
      if (k == 0) ops.copy(z, x);  // preconditioned steepest descent
      result.iterations = k;
      result.relative_residual = ops.norm(r) / b_norm;
      result.message = "non-positive curvature in CG; step truncated";
      return result;
    }
    const double alpha = rz / curvature;
    ops.axpy(alpha, p, x);
    ops.axpy(-alpha, hp, r);
    result.iterations = k + 1;
    result.relative_residual = ops.norm(r) / b_norm;
    if (!settings.fixed_iterations && result.relative_residual <= settings.tolerance) {
      result.converged = true;
      return result;
    }
    precondition(r, z);
    ops.project(z);
    const double rz_new = ops.dot(r, z);
    const double beta = rz_new / rz;
    rz = rz_new;
    ops.xpay(z, beta, p);
  }
  result.converged = settings.fixed_iterations || result.relative_residual <= settings.tolerance;
  if (!result.converged) result.message = "CG reached its iteration cap";
  return result;
}

// The identity preconditioner (plain CG): z = r.
template <class Ops>
struct IdentityPreconditioner {
  const Ops& ops;
  void operator()(const typename Ops::Vector& r, typename Ops::Vector& z) const { ops.copy(r, z); }
};

}  // namespace fascia
