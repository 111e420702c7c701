// Solves of H x = b with a factorisation of H (solve/linear_solver.hpp), written once over a
// backend's vector operations (solve/vector_ops.hpp).
//
// direct_solve: the cholmod method, a factorisation per solve (the CPU's CHOLMOD).
// pcg_with_kept_factorisation: pcg with the cholmod preconditioner, a factorisation kept from one
// solve to the next (the CPU's CHOLMOD; on the CUDA backend the dense device factor of
// kernels/device_cholesky.hpp). The factorisation is computed when stale, reused by later solves
// (Newton iterations and steps), renewed before the next solve once the factorisation says it
// stops paying (the CPU's rule: solve/kept_factorisation.hpp), and computed again at once when
// the reused one could not reach the tolerance within the cap. The state between solves is a
// KeptFactorisation, which a checkpoint keeps. Where H is indefinite (PCG meets non-positive
// curvature) and the factor is of a shifted H + tau diag|H|, the solve returns that matrix's
// step F^{-1} b instead of CG's truncated iterate: the modified Newton step (Nocedal & Wright,
// Numerical Optimization, 2nd ed., §3.4), a descent direction since F is positive definite, and
// the step direct_solve takes (a truncated iterate of a few CG iterations moves the state only a
// little along the negative curvature per Newton iteration).
//
// Factorisation concept:
//   LinearResult factorise();                 factorises H now: .factorised = true, .shifted and
//                                             .message when H + tau diag|H| was factorised, or
//                                             .message alone when it failed
//   bool factorised() const;                  a factor is held
//   void solve(const Vector& r, Vector& z);   z = F^{-1} r
//   bool shifted() const;                     the factor held is of H + tau diag|H|, tau > 0
//   bool stops_paying(const KeptFactorisation& kept, int iterations) const;
//                                             after a solve of `iterations` that `kept` has
//                                             counted: whether to renew the factorisation before
//                                             the next solve
#pragma once

#include "solve/kept_factorisation.hpp"
#include "solve/linear_solver.hpp"
#include "solve/pcg.hpp"

namespace fascia {

// The PCG settings of an iterative solve by `linear` (its tolerance, cap and fixed-iteration mode).
inline PcgSettings pcg_settings(const LinearSettings& linear) {
  PcgSettings s;
  s.tolerance = linear.tolerance;
  s.max_iterations = linear.max_iterations;
  s.fixed_iterations = linear.fixed_iterations;
  return s;
}

template <class Ops, class Apply, class Factorisation>
LinearResult direct_solve(const Ops& ops, Apply&& apply, Factorisation& factor, const typename Ops::Vector& b,
                          typename Ops::Vector& x) {
  using Vector = typename Ops::Vector;
  LinearResult r = factor.factorise();
  if (!factor.factorised()) return r;
  Vector rhs, hx;
  ops.copy(b, rhs);
  ops.project(rhs);
  ops.resize(x);
  factor.solve(rhs, x);
  ops.project(x);
  ops.resize(hx);
  apply(x, hx);
  ops.project(hx);
  ops.axpy(-1.0, rhs, hx);
  const double b_norm = ops.norm(rhs);
  r.relative_residual = b_norm > 0 ? ops.norm(hx) / b_norm : 0.0;
  return r;
}

template <class Ops, class Apply, class Factorisation>
LinearResult pcg_with_kept_factorisation(const Ops& ops, Apply&& apply, Factorisation& factor, KeptFactorisation& kept,
                                         const LinearSettings& settings, const typename Ops::Vector& b,
                                         typename Ops::Vector& x) {
  using Vector = typename Ops::Vector;
  const PcgSettings pcg_settings = fascia::pcg_settings(settings);
  auto factorise = [&] {
    LinearResult f = factor.factorise();
    if (factor.factorised()) kept = KeptFactorisation{false, 0, 0};
    return f;
  };
  const bool was_stale = kept.stale || !factor.factorised();
  LinearResult fresh;
  if (was_stale) {
    fresh = factorise();
    if (!factor.factorised()) return fresh;
  }
  auto precondition = [&](const Vector& r, Vector& z) { factor.solve(r, z); };
  LinearResult r = pcg(ops, apply, precondition, pcg_settings, b, x);
  int served = r.iterations;  // by the factorisation held now
  if (!r.converged && !was_stale && !settings.fixed_iterations) {
    const int spent = r.iterations;
    fresh = factorise();
    if (!factor.factorised()) return fresh;
    r = pcg(ops, apply, precondition, pcg_settings, b, x);
    served = r.iterations;
    r.iterations += spent;
  }
  if (r.negative_curvature && factor.shifted()) {  // the modified Newton step
    Vector rhs;
    ops.copy(b, rhs);
    ops.project(rhs);
    factor.solve(rhs, x);
    ops.project(x);
    r.message = "non-positive curvature in CG; the step of the shifted tangent's factor";
  }
  r.factorised = was_stale || fresh.factorised;
  r.shifted = fresh.shifted;
  ++kept.solves;
  kept.iterations += served;
  if (factor.stops_paying(kept, served)) kept.stale = true;
  return r;
}

}  // namespace fascia
