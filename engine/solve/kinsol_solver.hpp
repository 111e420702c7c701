// KINSOL (SUNDIALS 6, Hindmarsh et al., ACM TOMS 31(3), 2005) as the nonlinear solver of a step:
// `solver.nonlinear: kinsol` (docs/solvers.md), the alternative to newton() (solve/newton.hpp) on
// the CPU engine.
//
// Unknowns. KINSOL adds its steps linearly (u <- u + lambda p), frames' rotations do not: its
// unknown is the increment theta [N][6] in the chart at the solve's starting state q_0,
// q(theta) = q_0 (+) theta (the problem's retract: x = x_0 + theta_x, R = exp([theta_r]x) R_0, the
// rigidly mapped frames following their bodies), and theta = 0 at the start. The rotations of one
// step stay far below the chart's singularity at |theta_r| = pi.
//
// System. F(theta) = f(q(theta)), f the problem's residual in increments re-centred at q(theta)
// (the potential's projected gradient, or the variational step's residual): f and the gradient
// in the fixed chart differ by an invertible matrix (J_l^T per rotation), so they vanish together.
// The problem's operator H(q) (the symmetric tangent of the re-centred increments, the engine's
// tangent product) maps a re-centred increment d to the change of f; in the chart the same motion
// is p with d_r = J_l(theta_r) p_r (exp([theta_r + p_r]x) = exp([J_l(theta_r) p_r]x) exp([theta_r]x)
// + O(p^2); Barfoot, State Estimation, eq. 7.77a), so
//   Jacobian-vector product  J v = H(q) T(theta) v,   T = diag(I, J_l(theta_r)) per frame,
//   Newton step              p = T(theta)^{-1} d,      H(q) d = -F,
// exact up to the skew part of f's derivative, which is proportional to f and vanishes at the
// solution (DESIGN.md), as for newton().
//
// Linear solver. A custom SUNLinearSolver (type ITERATIVE: KINSOL sees only products) whose solve
// prepares H at the current iterate (full Newton, as newton()) and solves with the engine's
// LinearSolver (PCG with the reused CHOLMOD factorisation, block Jacobi, CG or the direct CHOLMOD
// solve, solve/linear_solver.hpp) at the settings' linear tolerance, as newton() does (KINSOL's
// inexact-Newton forcing terms, looser, measured failing: docs/solvers.md). KINSOL's line search
// takes its slope F.(J p) from the Jacobian-vector product above. Vectors: serial N_Vectors
// wrapping theta without a copy; f and the solves go through the engine's std::vector buffers
// (one copy of 6N doubles each, small beside an evaluation).
//
// Globalisation. KINSOL's line search (KIN_LINESEARCH: Dennis & Schnabel's backtracking on
// |F|^2 / 2 with the alpha and beta conditions) instead of newton()'s Armijo search on the
// potential; newton.max_backtracks does not apply (KINSOL stops when the step falls below its
// scaled step tolerance).
//
// Convergence: the same test as newton(): |f_free|_2 <= tolerance * max(reference force, |f(q_0)|).
// KINSOL's own test is on the max norm of the scaled residual (fscale = 1 / that force); it is
// given that tolerance first, and when its answer misses the 2-norm test it continues from there
// with its target lowered in proportion, within newton.max_iterations iterations in all.
//
// Failure: the state is left at the starting state or the last admissible iterate with a finite
// residual, never a non-finite one; the result's message names KINSOL's return flag.
#pragma once

#include "model/model.hpp"
#include "model/state.hpp"
#include "solve/linear_solver.hpp"
#include "solve/newton.hpp"

#include <vector>

namespace fascia {

// A nonlinear system f(q) = 0 on frame configurations for kinsol_solve().
class KinsolProblem {
 public:
  virtual ~KinsolProblem() = default;
  virtual const Model& model() const = 0;
  // f(q) [6N] in increments re-centred at q, zero at the fixed DOFs (of the model and of the
  // rigidly mapped frames). Returns false when q is not admissible (a non-finite value).
  virtual bool residual(const State& q, std::vector<double>& f) = 0;
  // c H(q), the operator whose solve c H d = -c f gives the re-centred Newton step, for the
  // constant c = jacobian_scale().
  virtual LinearSystem jacobian(const State& q) = 0;
  virtual double jacobian_scale() const { return 1.0; }
  // q <- q (+) scale d.
  virtual void retract(State& q, const double* d, double scale) const = 0;
};

// Solves problem.residual(state) = 0 from `state` with KINSOL (see above), linear solves by
// `solver` with settings.linear. reference_force (N): the scale of the relative residual, as for
// newton(). On success `state` is the solution; otherwise the last admissible iterate.
NewtonResult kinsol_solve(KinsolProblem& problem, State& state, const NewtonSettings& settings,
                          double reference_force, LinearSolver& solver);

// kinsol_solve() on a CPU Potential: f = its projected gradient, H its Hessian (the result's
// value is not computed).
NewtonResult kinsol_minimise(Potential& potential, State& state, const NewtonSettings& settings,
                             double reference_force, LinearSolver& solver);

}  // namespace fascia
