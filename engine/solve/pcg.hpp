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
//
// The iteration's scalars (rho = r^T z, alpha, beta, |b|, |r|) and its stopping tests live with
// the backend (Ops::CgScalars): an iteration that stops leaves x and r as they are, and the ones
// after it change nothing. The loop reads them with cg_status(): every iteration where they are
// host values; on a device, which would wait for its queue at each read, at the iterations where
// the residual's rate so far predicts the tolerance (next_status_read), so a solve runs its
// iterations without waiting and reads back a few times, and every iteration, the first
// included, is one record made once per solve and replayed (Ops::repeated). Either way the result
// is that of the iteration that stopped.
#pragma once

#include "core/stop_request.hpp"
#include "solve/linear_result.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace fascia {

struct PcgSettings {
  double tolerance = 1e-8;        // relative residual |r| / |b| to stop at
  int max_iterations = 2000;
  bool fixed_iterations = false;  // run exactly max_iterations
};

// The most iterations between two reads of a device's status: a solve that stops between two
// reads runs the products of the iterations up to the next one for nothing.
constexpr int kMaxIterationsBetweenReads = 8;

// The iterations after `k` (k iterations done, relative residual `residual`, and `previous` at
// iteration `k_previous` < k) until the residual should reach `tolerance` at the geometric rate
// seen between the two, at least 1 and at most kMaxIterationsBetweenReads: rounded down, since
// reading early costs one wait and reading late costs whole iterations.
inline int next_status_read(int k_previous, double previous, int k, double residual, double tolerance) {
  if (!(residual > tolerance)) return 1;
  const double rate = std::pow(residual / previous, 1.0 / std::max(1, k - k_previous));
  if (!(rate > 0 && rate < 1)) return 1;
  const double remaining = std::log(tolerance / residual) / std::log(rate);
  return static_cast<int>(std::clamp(std::floor(remaining), 1.0, static_cast<double>(kMaxIterationsBetweenReads)));
}

// @param apply          callable (const Vector& p, Vector& out): out = H p (projection not needed)
// @param precondition   callable (const Vector& r, Vector& z): z = M^{-1} r, M symmetric positive
//                       definite on the free DOFs (z is read through the projection)
// @param b              right-hand side [n]; projected here
// @param x              solution [n], resized; starts from zero
template <class Ops>
struct IdentityPreconditioner;

template <class Ops, class Apply, class Precondition>
LinearResult pcg(const Ops& ops, Apply&& apply, Precondition&& precondition, const PcgSettings& settings,
                 const typename Ops::Vector& b_in, typename Ops::Vector& x) {
  using Vector = typename Ops::Vector;
  // Plain CG: z is r itself (r is projected), with no copy and no product of its own.
  constexpr bool kIdentity = std::is_same_v<std::decay_t<Precondition>, IdentityPreconditioner<Ops>>;
  Vector r, z_own, p, hp;
  Vector& z = kIdentity ? r : z_own;
  ops.copy(b_in, r);  // r = P b: the residual of x = 0
  ops.project(r);
  ops.fill(x, 0.0);
  ops.fill(p, 0.0);  // the first direction is P z + 0 p
  if constexpr (!kIdentity) ops.resize(z);
  ops.resize(hp);
  LinearResult result;
  typename Ops::CgScalars scalars;
  // |b| and the stopping test from r; b = 0 stops here with x = 0.
  ops.cg_start(scalars, r, z, settings.fixed_iterations ? -1.0 : settings.tolerance);
  // An iteration: the next direction (the first is P z), then H p and the step along p. cg_step and
  // cg_direction read H p and z through the projection. The iterations between two reads of the
  // status have no host reads: the backend may record an iteration once per solve and replay the
  // record (Ops::repeated).
  auto iteration = [&] {
    if constexpr (!kIdentity) precondition(r, z);
    ops.cg_direction(scalars, r, z, p);  // beta = rho' / rho (0 at first), p = P z + beta p
    apply(p, hp);
    ops.cg_step(scalars, p, hp, z, x, r);  // alpha = rho / p^T H p, x += alpha p, r -= alpha P H p
  };
  auto repeated = ops.repeated(iteration);
  CgStatus status;  // as of the last read
  int k = 0, k_read = 0, next_read = 1;
  double residual_read = 1;  // |r| / |b| at iteration k_read (r = b at the start)
  while (k < settings.max_iterations) {
    throw_if_stop_requested();  // a stop takes effect within kMaxIterationsBetweenReads products
    const int read_at = std::min(next_read, settings.max_iterations);
    repeated.run(read_at - k);
    k = read_at;
    status = ops.cg_status(scalars);
    if (status.stopped || k == settings.max_iterations) break;
    if (Ops::kScalarsOnHost)
      next_read = k + 1;
    else if (!settings.fixed_iterations)
      next_read = k + next_status_read(k_read, residual_read, k, status.relative_residual, settings.tolerance);
    else
      next_read = settings.max_iterations;
    k_read = k;
    residual_read = status.relative_residual;
  }
  result.iterations = status.iterations;
  result.relative_residual = status.relative_residual;
  if (status.negative_curvature) {
    result.negative_curvature = true;
    result.message = "non-positive curvature in CG; step truncated";
    return result;
  }
  result.converged = settings.fixed_iterations || result.relative_residual <= settings.tolerance;
  if (!result.converged) result.message = "CG reached its iteration cap";
  return result;
}

// The identity preconditioner (plain CG): z = r. pcg() recognises it and takes r itself for z,
// which lets a backend form r^T z with the residual's r^T r (vector_ops.hpp, cg_step).
template <class Ops>
struct IdentityPreconditioner {
  const Ops& ops;
  void operator()(const typename Ops::Vector& r, typename Ops::Vector& z) const { ops.copy(r, z); }
};

}  // namespace fascia
