// Newton's method with a backtracking line search (DESIGN.md), written once over a backend's
// vector operations (solve/vector_ops.hpp) and a problem that supplies states:
// q_{k+1} = q_k (+) alpha d with H d = -g.
//
// A Problem provides
//
//   using Ops = ...;  using Vector = typename Ops::Vector;  using State = ...;
//   const Ops& ops() const;                  vector operations with the unknowns' fixed DOFs
//   bool minimises() const;                  true: g is the gradient of a potential Phi and the
//                                            line search is Armijo's on Phi; false: g is only a
//                                            residual and a step must decrease |g|
//   double gradient(const State& q, Vector& g);   g(q) [n], projected; returns Phi(q) when
//                                            minimises() (else any finite value; non-finite
//                                            means q is not admissible, e.g. inverted elements)
//   double value(const State& q);            Phi(q) (called only when minimises())
//   LinearResult solve(const State& q, const Vector& rhs, Vector& d, const LinearSettings& linear);
//                                            d = H(q)^{-1} rhs on the free DOFs by `linear`
//                                            (PCG, solve/pcg.hpp, or direct): settings.linear
//                                            with this iteration's tolerance (below)
//   void retract(State& q, const Vector& d, double alpha);   q <- q (+) alpha d
//
// States are assigned (trial = q) and swapped during the line search.
//
// Inexact Newton (Eisenstat & Walker, SIAM J. Sci. Comput. 17, 1996; Kelley, Iterative Methods
// for Linear and Nonlinear Equations, 1995, §6.1): an iterative solve stops at
// |H d + g| <= eta_k |g| with the forcing term
//
//   eta_k = min(kForcingMax, max(kForcing r_k, kForcingFloor tolerance / r_k)),   r_k = |g_k| / scale,
//
// never below settings.linear.tolerance. eta_k proportional to r_k keeps Newton's quadratic
// local convergence; far from the solution a loose solve costs few CG iterations and loses
// nothing, since the linearisation itself is that far off. Near the solution the floor (Kelley,
// eq. 6.20) asks the solve for no more than the Newton tolerance: a step solved to eta_k leaves a
// residual of about eta_k r_k plus the linearisation's O(r_k^2), so eta_k = kForcingFloor
// tolerance / r_k ends the solve at half the tolerance, where kForcing r_k would end it orders of
// magnitude below (r_k = 1e-4 and tolerance 1e-6: 5e-3 instead of 1e-5, half the CG iterations
// of that last solve).
//
// Convergence: |g_free| <= tolerance * max(reference force, |g_free(q_0)|). Line search: halve
// alpha until Phi(q (+) alpha d) <= Phi(q) + armijo alpha g.d (Nocedal & Wright, eq. 3.4); near
// the minimum the predicted decrease falls below the round-off of Phi (a sum of many terms), and
// there, as for residual problems, a step that reduces |g| is accepted. The full step's Phi is
// the one its gradient returns (accepted, that gradient is the next iteration's); shortened steps
// evaluate Phi alone.
//
// Residual problems whose solve is an approximation of the Jacobian J of g (the variational step's
// symmetric iteration matrix) converge linearly, and where the approximation is poor its direction
// need not decrease |g| at all. From the first iteration whose line search fails, the solve's
// directions give way to Newton-Krylov ones (Knoll & Keyes, "Jacobian-free Newton-Krylov
// methods", J. Comput. Phys. 193, 2004): J d = -g by FGMRES (solve/fgmres.hpp) with products
// J z = (g(q (+) eps z) - g(q)) / eps, preconditioned by the problem's solve; that iteration is
// taken again along the new direction, and so are the rest of the solve's. To the accuracy of the
// difference quotient and the forcing term, d is J's Newton step, a descent direction of |g|^2.
// Where FGMRES cannot reduce the linearised residual below kKrylovStall |g|, J^T g is about zero:
// |g| is at a minimum away from zero (the equations have no solution near q), and the solve stops
// there rather than take iterations that cannot progress.
#pragma once

#include "core/stop_request.hpp"
#include "model/state.hpp"
#include "solve/fgmres.hpp"
#include "solve/linear_solver.hpp"
#include "solve/step_controller.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <utility>

namespace fascia {

// The forcing term's constants (see above). On the shipped scenes eta_k = 0.1 |g_k| / scale
// capped at 1e-2 takes 45 % fewer CG iterations than 1e-8 throughout, at the same Newton
// iterations within 3 %; a cap of 1e-1 adds up to a quarter more Newton iterations. The floor's
// 0.5 is Kelley's; 0.25 and 1 take CG iterations within 7 % of its on the shipped scenes but for
// tool_pull at 1, 17 % more (an H200, docs/benchmarks.md).
constexpr double kForcing = 0.1;
constexpr double kForcingMax = 1e-2;
constexpr double kForcingFloor = 0.5;

// The forcing term eta_k of Newton's iteration at relative residual r_k = |g_k| / scale for the
// Newton tolerance `tolerance` (above), before the linear tolerance's floor.
inline double forcing_term(double r_k, double tolerance) {
  if (!(r_k > 0)) return kForcingMax;  // g = 0 (fixed-iteration runs): any solve is exact
  return std::min(kForcingMax, std::max(kForcing * r_k, kForcingFloor * tolerance / r_k));
}

// Newton-Krylov directions (see above). The difference step eps |z| = 1e-7 (m and rad of the
// increments) balances the quotient's truncation, about 1e-7 of J's scale over the variation of J
// across a rotation of one radian or a translation of the model's size (>= 1 cm), against the
// round-off of g, about 1e-16 of its largest terms (momenta over h, forces) over 1e-7 |J z|:
// both well below the forcing term's 1e-2 .. 1e-8 relative accuracy on the shipped scenes.
// FGMRES keeps at most kKrylovIterations directions, each one preconditioning solve (at the
// forcing term's cap, kForcingMax) and one evaluation of g.
constexpr double kDifferenceStep = 1e-7;
constexpr int kKrylovIterations = 20;
constexpr double kKrylovStall = 0.99;

struct NewtonSettings {
  double tolerance = 1e-6;   // converged when |g_free| <= tolerance * reference force
  int max_iterations = 50;
  int max_backtracks = 30;   // halvings of the step in the line search
  double armijo = 1e-4;      // sufficient decrease constant
  // Take exactly this many Newton iterations and no line search when > 0 (benchmarks: one
  // linearised implicit step as in the paper).
  int fixed_iterations = 0;
  LinearSettings linear;
};

// How a Newton solve ended (NewtonResult::stop).
enum class NewtonStop {
  converged,
  inadmissible_start,  // the starting state has non-finite energy or gradient
  line_search,         // no step along the direction decreased Phi (or |g|)
  krylov_stall,        // Newton-Krylov: GMRES could not reduce the linearised residual
  inadmissible_probe,  // Newton-Krylov: a difference quotient's state is not admissible
  iteration_cap,       // max_iterations without reaching the tolerance
  non_finite,          // fixed_iterations ended at a state of non-finite energy or gradient
};

struct NewtonResult {
  NewtonStop stop = NewtonStop::iteration_cap;  // why it stopped (a result not yet reached: the cap)
  int iterations = 0;
  int cg_iterations = 0;
  double residual = 0;   // |g_free| / scale at the end
  double scale = 0;      // the force scale: max(reference force, |g_free(q_0)|) (0: q_0 not admissible)
  double value = 0;      // Phi at the end (minimising problems)
  std::string message;   // why it stopped, when not converged
  bool converged() const { return stop == NewtonStop::converged; }
};

// The Newton-Krylov direction of a residual problem at q (see above): J d = rhs to the relative
// tolerance of `linear`, g = g(q), `probe` the state of the difference quotients.
template <class Problem>
LinearResult newton_krylov_direction(Problem& problem, const typename Problem::State& q,
                                     const typename Problem::Vector& g, const typename Problem::Vector& rhs,
                                     typename Problem::Vector& d, const LinearSettings& linear,
                                     std::optional<typename Problem::State>& probe) {
  using Vector = typename Problem::Vector;
  const auto& ops = problem.ops();
  auto jacobian = [&](const Vector& z, Vector& out) {
    const double z_norm = ops.norm(z);
    if (!(z_norm > 0)) {
      ops.fill(out, 0.0);
      return true;
    }
    const double eps = kDifferenceStep / z_norm;
    if (probe)
      *probe = q;
    else
      probe.emplace(q);
    problem.retract(*probe, z, eps);
    if (!std::isfinite(problem.gradient(*probe, out))) return false;
    ops.axpy(-1.0, g, out);
    ops.scale(1 / eps, out);
    return true;
  };
  LinearSettings inner = linear;
  inner.tolerance = std::max(linear.tolerance, kForcingMax);
  auto precondition = [&](const Vector& v, Vector& z) { return problem.solve(q, v, z, inner).iterations; };
  FgmresSettings krylov;
  krylov.tolerance = linear.tolerance;
  krylov.max_iterations = kKrylovIterations;
  return fgmres(ops, jacobian, precondition, krylov, rhs, d);
}

template <class Problem>
NewtonResult newton(Problem& problem, typename Problem::State& state, const NewtonSettings& settings,
                    double reference_force) {
  using Vector = typename Problem::Vector;
  const auto& ops = problem.ops();
  const bool minimises = problem.minimises();
  Vector g, g_trial, d, rhs;
  ops.resize(g);
  ops.resize(g_trial);
  ops.resize(d);
  ops.resize(rhs);
  typename Problem::State trial = state;
  std::optional<typename Problem::State> probe;  // the Newton-Krylov difference quotients' state
  bool krylov = false;                           // Newton-Krylov directions (residual problems)
  NewtonResult result;
  double phi = problem.gradient(state, g);
  double g_norm = ops.norm(g);
  if (!std::isfinite(phi) || !std::isfinite(g_norm)) {
    result.stop = NewtonStop::inadmissible_start;
    result.message = "the starting state has non-finite energy (an inverted element, or magnitudes beyond a double: moduli, densities, loads?)";
    return result;
  }
  const double scale = std::max({reference_force, g_norm, 1e-300});
  result.scale = scale;
  const int iterations = settings.fixed_iterations > 0 ? settings.fixed_iterations : settings.max_iterations;
  for (int it = 0; it < iterations; ++it) {
    throw_if_stop_requested();  // core/stop_request.hpp: the step is abandoned
    result.residual = g_norm / scale;
    if (settings.fixed_iterations == 0 && result.residual <= settings.tolerance) {
      result.stop = NewtonStop::converged;
      break;
    }
    ops.copy(g, rhs);
    ops.scale(-1.0, rhs);
    LinearSettings linear = settings.linear;
    linear.tolerance = std::max(settings.linear.tolerance, forcing_term(result.residual, settings.tolerance));
    const LinearResult lin =
        krylov ? newton_krylov_direction(problem, state, g, rhs, d, linear, probe) : problem.solve(state, rhs, d, linear);
    result.cg_iterations += lin.iterations;
    if (krylov && !(lin.relative_residual < kKrylovStall)) {
      std::ostringstream msg;
      msg << "Newton-Krylov directions stalled at Newton iteration " << it + 1 << " (relative residual "
          << result.residual << "): ";
      result.stop = lin.product_failed ? NewtonStop::inadmissible_probe : NewtonStop::krylov_stall;
      if (lin.product_failed)
        msg << "a difference quotient's state is not admissible (an inverted element)";
      else
        msg << "GMRES reduced the linearised residual to " << lin.relative_residual
            << " of |g| only, a local minimum of the residual away from zero";
      result.message = msg.str();
      result.value = phi;
      return result;
    }
    double slope = ops.dot(g, d);
    // Not a descent direction: steepest descent (a Newton-Krylov step descends on |g|^2, whatever
    // the sign of g.d).
    if (!krylov && !(slope < 0)) {
      ops.copy(rhs, d);
      slope = -g_norm * g_norm;
    }
    ++result.iterations;
    if (settings.fixed_iterations > 0) {  // one linearised step per iteration, no line search
      problem.retract(state, d, 1.0);
      phi = problem.gradient(state, g);
      g_norm = ops.norm(g);
      continue;
    }
    double alpha = 1.0;
    bool accepted = false;
    for (int b = 0; b <= settings.max_backtracks && !accepted; ++b, alpha *= 0.5) {
      throw_if_stop_requested();
      trial = state;
      problem.retract(trial, d, alpha);
      // The full step is accepted in most iterations: there the gradient, which returns Phi too,
      // is evaluated at once; a shortened step first evaluates Phi alone.
      const bool full_step = b == 0;
      double phi_trial = 0;
      if (minimises) {
        phi_trial = full_step ? problem.gradient(trial, g_trial) : problem.value(trial);
        if (!std::isfinite(phi_trial)) continue;
        if (phi_trial <= phi + settings.armijo * alpha * slope) {
          std::swap(state, trial);
          if (full_step) {
            std::swap(g, g_trial);
            phi = phi_trial;
          } else {
            phi = problem.gradient(state, g);
          }
          g_norm = ops.norm(g);
          accepted = true;
          break;
        }
        const bool round_off = std::abs(alpha * slope) <= 1e-10 * std::abs(phi) &&
                               std::abs(phi_trial - phi) <= 1e-10 * std::abs(phi);
        if (!round_off) continue;
      }
      if (!(minimises && full_step)) phi_trial = problem.gradient(trial, g_trial);
      const double trial_norm = ops.norm(g_trial);
      if (std::isfinite(phi_trial) && std::isfinite(trial_norm) && trial_norm < g_norm) {
        std::swap(state, trial);
        std::swap(g, g_trial);
        phi = phi_trial;
        g_norm = trial_norm;
        accepted = true;
      }
    }
    if (!accepted && !minimises && !krylov) {  // this iteration again, along J's Newton step
      krylov = true;
      continue;
    }
    if (!accepted) {
      std::ostringstream msg;
      msg << "line search failed after " << settings.max_backtracks << " halvings at Newton iteration " << it + 1
          << (krylov ? " along the Newton-Krylov direction" : "") << " (relative residual " << result.residual << ")";
      result.stop = NewtonStop::line_search;
      result.message = msg.str();
      result.value = phi;
      return result;
    }
  }
  result.residual = g_norm / scale;
  result.value = phi;
  if (settings.fixed_iterations > 0) {
    result.stop = std::isfinite(phi) && std::isfinite(g_norm) ? NewtonStop::converged : NewtonStop::non_finite;
  } else if (!result.converged()) {
    if (result.residual <= settings.tolerance) {
      result.stop = NewtonStop::converged;
    } else {
      result.stop = NewtonStop::iteration_cap;
      std::ostringstream msg;
      msg << "Newton did not converge in " << settings.max_iterations << " iterations (relative residual "
          << result.residual << ", tolerance " << settings.tolerance << ")";
      result.message = msg.str();
    }
  }
  return result;
}

// Static load stepping around newton(): the load factor goes from 0 to 1 in increments sized by
// the step controller (solve/step_controller.hpp) on the Newton iterations each took: the first
// is 1 / initial_steps, a failed one is halved (down to the first halved max_halvings times),
// the next after a converged one of I iterations is h * clamp(0.9 sqrt(max_iterations / I), 0.2,
// 2), not larger than h right after a failure. set_load_factor(f) applies factor f to the
// problem's loads and returns the reference force of the residual at that factor (N). On failure
// the state is left at the last converged factor and the result's message says where it stopped.
struct LoadStepping {
  int initial_steps = 1;   // first increment = 1 / initial_steps
  int max_halvings = 10;   // smallest increment = the first / 2^max_halvings
};

template <class Problem, class SetLoadFactor>
NewtonResult newton_load_stepping(Problem& problem, typename Problem::State& state, const NewtonSettings& settings,
                                  const LoadStepping& stepping, SetLoadFactor&& set_load_factor) {
  const double first = 1.0 / std::max(1, stepping.initial_steps);
  AdaptiveSettings control;
  control.tolerance = 1.0;  // the error is the share of the Newton budget an increment used
  // Exact, as halving is: the smallest increment is tried once, then the solve gives up.
  control.min_dt = std::ldexp(first, -std::max(0, stepping.max_halvings));
  StepController controller(control, first, 2);
  // With fixed_iterations every increment takes the same count: no difficulty to measure.
  const double budget = settings.fixed_iterations > 0 ? 0.0 : static_cast<double>(settings.max_iterations);
  double done = 0;
  NewtonResult total, last;
  typename Problem::State attempt = state;
  while (done < 1.0) {
    const double increment = controller.next_step(done, 1.0);
    const double target = increment >= 1.0 - done ? 1.0 : done + increment;
    const double reference = set_load_factor(target);
    attempt = state;
    NewtonResult r;
    try {
      r = newton(problem, attempt, settings, reference);
    } catch (const StopRequested&) {
      set_load_factor(1.0);  // an abandoned step leaves the loads at full scale
      throw;
    }
    total.iterations += r.iterations;
    total.cg_iterations += r.cg_iterations;
    if (r.converged()) {
      std::swap(state, attempt);
      done = target;
      last = r;
      controller.update(increment, budget > 0 ? r.iterations / budget : 0.0);
      continue;
    }
    if (!controller.failed(increment)) {
      set_load_factor(1.0);
      std::ostringstream msg;
      msg << "static solve failed at load factor " << target << ": " << r.message;
      total.message = msg.str();
      total.stop = r.stop;
      total.residual = r.residual;
      return total;
    }
  }
  total.stop = NewtonStop::converged;
  total.residual = last.residual;
  total.value = last.value;
  return total;
}

// A potential on frame configurations with gradient and Hessian w.r.t. increments
// theta (DESIGN.md): Phi(q (+) theta), theta in [N][6]. The CPU's problems (StepPotential).
class Potential {
 public:
  virtual ~Potential() = default;
  virtual const Model& model() const = 0;
  virtual double value(const State& state) = 0;
  // Value and gradient at theta = 0.
  virtual double gradient(const State& state, std::vector<double>& g) = 0;
  // Prepares the Hessian at state for the system() operator.
  virtual void prepare_hessian(const State& state) = 0;
  virtual LinearSystem system() = 0;
  // q <- q (+) scale d. Potentials whose configuration space is constrained (rigidly mapped
  // frames) restore their constraints here.
  virtual void retract(State& state, const double* d, double scale) const {
    ::fascia::retract(model(), state, d, scale);
  }
};

// newton() on a CPU Potential with HostVectorOps, solving with `solver` (which keeps its
// factorisation from one call to the next; null: a solver for this call only).
NewtonResult minimise(Potential& potential, State& state, const NewtonSettings& settings, double reference_force,
                      LinearSolver* solver = nullptr);

// newton_load_stepping() on a CPU Potential, as minimise().
NewtonResult minimise_load_stepping(Potential& potential, State& state, const NewtonSettings& settings,
                                    const LoadStepping& stepping, const std::function<double(double)>& set_load_factor,
                                    LinearSolver* solver = nullptr);

// Norm of g over the model's free DOFs.
double free_norm(const Model& model, const std::vector<double>& g);

}  // namespace fascia
