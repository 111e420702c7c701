#include "solve/kinsol_solver.hpp"

#include "core/small_math.hpp"
#include "core/stop_request.hpp"
#include "mechanics/frame_inertia.hpp"
#include "solve/vector_ops.hpp"

#include <kinsol/kinsol.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <memory>
#include <sstream>
#include <string>

namespace fascia {

namespace {

// Everything KINSOL's callbacks reach through their user data.
struct Run {
  Run(KinsolProblem& p, const State& start, const LinearSettings& l, LinearSolver& s)
      : problem(p), linear(l), solver(s), base(start), n(p.model().dof_count()) {}

  KinsolProblem& problem;
  const LinearSettings& linear;
  LinearSolver& solver;
  const State base;              // q_0, the chart's centre
  const int n;                   // 6N unknowns
  State q;                       // q(theta) of the last evaluation
  std::vector<double> theta_f;   // theta of the last evaluation [6N]
  std::vector<double> f;         // its residual [6N]
  LinearSystem system;           // c H at the last solve
  std::vector<double> theta_h;   // theta of that solve [6N]
  std::vector<double> rhs, d, v, hv;
  int cg_iterations = 0;         // every linear solve's iterations
  int last_iterations = 0;       // the last solve's
  double last_residual = 0;      // its relative residual
  std::string linear_message;    // why the last solve failed
  std::string kinsol_message;    // KINSOL's last error message
  std::exception_ptr exception;  // thrown in a callback (a stop request): rethrown after KINSol
};

double* data(N_Vector x) { return N_VGetArrayPointer(x); }

// q <- q_0 (+) theta.
void evaluate_at(Run& r, const double* theta) {
  r.q = r.base;
  r.problem.retract(r.q, theta, 1.0);
}

// The rotational blocks of T(theta) (see the header): J_l(theta_r) = (J_l^{-1}(theta_r))^{-1}.
Vec3 rotation_part(const double* x, int i) { return {x[6 * i + 3], x[6 * i + 4], x[6 * i + 5]}; }

// out = T(theta) v.
void to_recentred(const std::vector<double>& theta, const double* v, double* out, int frames) {
  for (int i = 0; i < frames; ++i) {
    for (int k = 0; k < 3; ++k) out[6 * i + k] = v[6 * i + k];
    const Mat3 jl = transpose(inverse_transpose(inverse_left_jacobian(rotation_part(theta.data(), i))));
    store3(&out[6 * i + 3], jl * rotation_part(v, i));
  }
}

// out = T(theta)^{-1} d.
void to_chart(const std::vector<double>& theta, const double* d, double* out, int frames) {
  for (int i = 0; i < frames; ++i) {
    for (int k = 0; k < 3; ++k) out[6 * i + k] = d[6 * i + k];
    store3(&out[6 * i + 3], inverse_left_jacobian(rotation_part(theta.data(), i)) * rotation_part(d, i));
  }
}

// F(theta): 0 on success, 1 (recoverable: KINSOL shortens the step) where q(theta) is not
// admissible, -1 on an exception (kept and rethrown).
int residual_callback(N_Vector uu, N_Vector fval, void* user_data) {
  Run& r = *static_cast<Run*>(user_data);
  try {
    throw_if_stop_requested();
    r.theta_f.assign(data(uu), data(uu) + r.n);
    evaluate_at(r, data(uu));
    if (!r.problem.residual(r.q, r.f)) return 1;
    for (double x : r.f)
      if (!std::isfinite(x)) return 1;
    std::copy(r.f.begin(), r.f.end(), data(fval));
    return 0;
  } catch (...) {
    r.exception = std::current_exception();
    return -1;
  }
}

// J v = H(q) T(theta) v at the prepared u (the engine's tangent product).
int jtimes_callback(N_Vector v, N_Vector jv, N_Vector, booleantype*, void* user_data) {
  Run& r = *static_cast<Run*>(user_data);
  try {
    r.v.resize(r.n);
    r.hv.resize(r.n);
    to_recentred(r.theta_h, data(v), r.v.data(), r.n / 6);
    r.system.apply(r.v.data(), r.hv.data());
    const double c = 1.0 / r.problem.jacobian_scale();
    double* out = data(jv);
    for (int k = 0; k < r.n; ++k) out[k] = r.system.fixed[k] ? 0.0 : c * r.hv[k];
    return 0;
  } catch (...) {
    r.exception = std::current_exception();
    return -1;
  }
}

void error_callback(int, const char*, const char*, char* msg, void* user_data) {
  static_cast<Run*>(user_data)->kinsol_message = msg;
}

// The engine's linear solver as a SUNLinearSolver (type ITERATIVE: KINSOL gives products and
// asks for solves to a tolerance). Content: the Run.
Run& run_of(SUNLinearSolver ls) { return *static_cast<Run*>(ls->content); }

SUNLinearSolver_Type ls_type(SUNLinearSolver) { return SUNLINEARSOLVER_ITERATIVE; }
SUNLinearSolver_ID ls_id(SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; }
// KINSOL requires an iterative solver to accept its product; the engine's solver applies H itself.
int ls_set_atimes(SUNLinearSolver, void*, SUNATimesFn) { return SUNLS_SUCCESS; }
int ls_initialize(SUNLinearSolver) { return SUNLS_SUCCESS; }

// Solves J p = b at the current iterate u: c H(q(u)) d = c b by the engine's solver, p = T^{-1} d.
// tol bounds |J p - b|_2 (KINSOL scales it for fscale; see kinLsSolve). KINSOL calls a linear
// solver's setup only when a preconditioner is registered, and its solve with b = -F(u) where
// F(u) is its last evaluation (its line search re-evaluates the accepted point): H is prepared
// here at the theta of that evaluation, checked against b.
int ls_solve(SUNLinearSolver ls, SUNMatrix, N_Vector x, N_Vector b, realtype tol) {
  Run& r = run_of(ls);
  try {
    const double* bd = data(b);
    for (int k = 0; k < r.n; ++k)
      if (bd[k] != -r.f[k]) {
        r.linear_message = "KINSOL asked for a step at a point other than its last evaluation";
        return SUNLS_PACKAGE_FAIL_UNREC;
      }
    r.theta_h = r.theta_f;
    evaluate_at(r, r.theta_h.data());
    r.system = r.problem.jacobian(r.q);
    const double c = r.problem.jacobian_scale();
    r.rhs.assign(bd, bd + r.n);
    double b_norm = 0;
    for (int k = 0; k < r.n; ++k) {
      r.rhs[k] *= c;
      b_norm += bd[k] * bd[k];
    }
    b_norm = std::sqrt(b_norm);
    // The settings' relative tolerance, or KINSOL's where tighter. KINSOL's inexact-Newton forcing
    // terms alone (looser: 0.1 and above far from the solution) leave PCG's steps too rough for
    // its line search (docs/solvers.md).
    LinearSettings linear = r.linear;
    if (b_norm > 0 && !linear.fixed_iterations) linear.tolerance = std::min(linear.tolerance, tol / b_norm);
    const LinearResult result = r.solver.solve(r.system, linear, r.rhs, r.d);
    r.cg_iterations += result.iterations;
    r.last_iterations = result.iterations;
    r.last_residual = result.relative_residual;
    // A failed factorisation returns no direction (linear_solver.cpp): not converged, no iteration.
    if (r.d.size() != static_cast<size_t>(r.n) ||
        (!result.converged && !result.negative_curvature && result.iterations == 0)) {
      r.linear_message = result.message.empty() ? "the linear solve failed" : result.message;
      return SUNLS_PACKAGE_FAIL_UNREC;
    }
    for (double y : r.d)
      if (!std::isfinite(y)) {
        r.linear_message = "the linear solve returned a non-finite direction";
        return SUNLS_PACKAGE_FAIL_UNREC;
      }
    to_chart(r.theta_h, r.d.data(), data(x), r.n / 6);
    // Not converged within the cap (or truncated on negative curvature): still KINSOL's step,
    // which its line search tests.
    return result.converged ? SUNLS_SUCCESS : SUNLS_RES_REDUCED;
  } catch (...) {
    r.exception = std::current_exception();
    return SUNLS_PACKAGE_FAIL_UNREC;
  }
}
int ls_num_iters(SUNLinearSolver ls) { return run_of(ls).last_iterations; }
realtype ls_res_norm(SUNLinearSolver ls) { return run_of(ls).last_residual; }
sunindextype ls_last_flag(SUNLinearSolver) { return 0; }
int ls_free(SUNLinearSolver ls) {
  if (!ls) return SUNLS_SUCCESS;
  ls->content = nullptr;  // the Run is owned by kinsol_solve()
  SUNLinSolFreeEmpty(ls);
  return SUNLS_SUCCESS;
}

SUNLinearSolver make_linear_solver(SUNContext context, Run& run) {
  SUNLinearSolver ls = SUNLinSolNewEmpty(context);
  if (!ls) throw std::bad_alloc();
  ls->content = &run;
  ls->ops->gettype = ls_type;
  ls->ops->getid = ls_id;
  ls->ops->setatimes = ls_set_atimes;
  ls->ops->initialize = ls_initialize;
  ls->ops->solve = ls_solve;
  ls->ops->numiters = ls_num_iters;
  ls->ops->resnorm = ls_res_norm;
  ls->ops->lastflag = ls_last_flag;
  ls->ops->free = ls_free;
  return ls;
}

// Owners of the SUNDIALS objects of one solve.
struct Context {
  SUNContext context = nullptr;
  ~Context() { SUNContext_Free(&context); }
};
struct Vector {
  N_Vector v = nullptr;
  ~Vector() { N_VDestroy(v); }
};
struct Memory {
  void* kinsol = nullptr;
  SUNLinearSolver ls = nullptr;
  ~Memory() {
    KINFree(&kinsol);
    ls_free(ls);
  }
};

std::string flag_name(int flag) {
  // SUNDIALS 6.4's KINGetReturnFlagName() answers "NONE" for these two.
  if (flag == KIN_REPTD_SYSFUNC_ERR) return "KIN_REPTD_SYSFUNC_ERR";
  if (flag == KIN_SYSFUNC_FAIL) return "KIN_SYSFUNC_FAIL";
  char* name = KINGetReturnFlagName(flag);
  std::string s = name ? name : "?";
  std::free(name);
  return s;
}

// What a KINSOL return flag means for a user.
std::string flag_meaning(int flag) {
  switch (flag) {
    case KIN_LINESEARCH_NONCONV: return "the line search could not find an acceptable step";
    case KIN_LINESEARCH_BCFAIL: return "the line search repeatedly failed its beta condition (slow progress)";
    case KIN_MAXITER_REACHED: return "the iteration limit was reached";
    case KIN_MXNEWT_5X_EXCEEDED: return "five steps in a row reached the maximum step length (diverging)";
    case KIN_LINSOLV_NO_RECOVERY:
    case KIN_LSOLVE_FAIL:
    case KIN_LSETUP_FAIL: return "the linear solve failed";
    case KIN_SYSFUNC_FAIL:
    case KIN_REPTD_SYSFUNC_ERR: return "the residual is non-finite along the step (an inverted element)";
    case KIN_STEP_LT_STPTOL: return "the step fell below KINSOL's step tolerance";
    default: return "";
  }
}

void check(int flag, const char* call) {
  if (flag < 0) throw std::runtime_error(std::string("KINSOL: ") + call + " failed (" + flag_name(flag) + ")");
}

}  // namespace

NewtonResult kinsol_solve(KinsolProblem& problem, State& state, const NewtonSettings& settings,
                          double reference_force, LinearSolver& solver) {
  NewtonResult result;
  Run run(problem, state, settings.linear, solver);
  const int n = run.n;
  if (!problem.residual(state, run.f)) {
    result.message = "the starting state has non-finite energy (an inverted element, or magnitudes beyond a double: "
                     "moduli, densities, loads?)";
    return result;
  }
  double f0 = 0;
  for (double x : run.f) f0 += x * x;
  f0 = std::sqrt(f0);
  if (!std::isfinite(f0)) {
    result.message = "the starting state has a non-finite residual";
    return result;
  }
  const double scale = std::max({reference_force, f0, 1e-300});
  result.residual = f0 / scale;
  if (result.residual <= settings.tolerance) {
    result.converged = true;
    return result;
  }

  Context context;
  check(SUNContext_Create(nullptr, &context.context), "SUNContext_Create");
  std::vector<double> theta(static_cast<size_t>(n), 0.0);
  Vector u, u_scale, f_scale;
  u.v = N_VMake_Serial(n, theta.data(), context.context);  // wraps theta, no copy
  u_scale.v = N_VNew_Serial(n, context.context);
  f_scale.v = N_VNew_Serial(n, context.context);
  if (!u.v || !u_scale.v || !f_scale.v) throw std::bad_alloc();
  N_VConst(1.0, u_scale.v);  // m and rad: increments of one step are far below 1
  N_VConst(1.0 / scale, f_scale.v);

  Memory memory;
  memory.kinsol = KINCreate(context.context);
  if (!memory.kinsol) throw std::bad_alloc();
  void* kin = memory.kinsol;
  check(KINSetErrHandlerFn(kin, error_callback, &run), "KINSetErrHandlerFn");
  check(KINInit(kin, residual_callback, u.v), "KINInit");
  check(KINSetUserData(kin, &run), "KINSetUserData");
  memory.ls = make_linear_solver(context.context, run);
  check(KINSetLinearSolver(kin, memory.ls, nullptr), "KINSetLinearSolver");
  check(KINSetJacTimesVecFn(kin, jtimes_callback), "KINSetJacTimesVecFn");
  // Forcing-term mode 1 is the one in which KINSOL measures its line search's slope F.(J p) with
  // the Jacobian-vector product (kinLsSolve); the tolerance it asks for is tightened to the
  // settings' in ls_solve().
  check(KINSetEtaForm(kin, KIN_ETACHOICE1), "KINSetEtaForm");
  // KINSOL's default caps |p|_2 at max(1000 |u_0|, 1) = 1 here, which would shorten the steps of
  // large models (|p|_2 sums over all frames); this cap is far above any step's increments.
  check(KINSetMaxNewtonStep(kin, 1e3 * std::sqrt(static_cast<double>(n))), "KINSetMaxNewtonStep");
  check(KINSetPrintLevel(kin, 0), "KINSetPrintLevel");

  // KINSOL's test is |F / scale|_inf <= target; the 2-norm test decides, and a miss continues
  // with the target lowered by the ratio of the two (at most the remaining iterations).
  double target = settings.tolerance;
  long iterations = 0;
  int flag = KIN_SUCCESS;
  std::vector<double> best = theta;  // the last admissible iterate
  // Each pass halves the target at least: 30 passes take it 1e9 times below the tolerance.
  for (int pass = 0; pass < 30; ++pass) {
    const long left = settings.max_iterations - iterations;
    if (left <= 0) {
      flag = KIN_MAXITER_REACHED;
      break;
    }
    check(KINSetNumMaxIters(kin, left), "KINSetNumMaxIters");
    check(KINSetFuncNormTol(kin, target), "KINSetFuncNormTol");
    flag = KINSol(kin, u.v, KIN_LINESEARCH, u_scale.v, f_scale.v);
    if (run.exception) std::rethrow_exception(run.exception);
    long nni = 0;
    KINGetNumNonlinSolvIters(kin, &nni);
    iterations += nni;
    // KINSol leaves u at its last accepted iterate; measure it.
    evaluate_at(run, theta.data());
    double norm = 0, max_norm = 0;
    const bool admissible = problem.residual(run.q, run.f);
    for (double x : run.f) {
      norm += x * x;
      max_norm = std::max(max_norm, std::abs(x));
    }
    norm = std::sqrt(norm);
    if (admissible && std::isfinite(norm)) {
      best = theta;
      result.residual = norm / scale;
    }
    if (flag < 0 || !admissible || !std::isfinite(norm)) break;
    if (result.residual <= settings.tolerance) {
      result.converged = true;
      break;
    }
    if (flag == KIN_STEP_LT_STPTOL) break;  // stagnates: no continuation helps
    // The max-norm test passed but the 2-norm did not: lower the target so that, for the same
    // distribution of the residual over the DOFs, the next answer meets the 2-norm test.
    target = std::min(0.5 * target, settings.tolerance * (max_norm / scale) / result.residual);
  }
  result.iterations = static_cast<int>(iterations);
  result.cg_iterations = run.cg_iterations;
  evaluate_at(run, best.data());
  state = run.q;
  if (!result.converged) {
    std::ostringstream msg;
    msg << "KINSOL did not converge (" << flag_name(flag);
    const std::string meaning = flag_meaning(flag);
    if (!meaning.empty()) msg << ": " << meaning;
    msg << ") after " << iterations << " iterations (relative residual " << result.residual << ", tolerance "
        << settings.tolerance << ")";
    if (!run.linear_message.empty()) msg << "; " << run.linear_message;
    else if (!run.kinsol_message.empty()) msg << "; " << run.kinsol_message;
    result.message = msg.str();
  }
  return result;
}

namespace {

// kinsol_solve()'s problem for a CPU Potential.
class PotentialProblem : public KinsolProblem {
 public:
  explicit PotentialProblem(Potential& potential)
      : m_potential(potential),
        m_ops(potential.model().dof_count(), potential.model().fixed_dofs.data()) {}
  const Model& model() const override { return m_potential.model(); }
  bool residual(const State& q, std::vector<double>& f) override {
    const double phi = m_potential.gradient(q, f);
    m_ops.project(f);
    return std::isfinite(phi);
  }
  LinearSystem jacobian(const State& q) override {
    m_potential.prepare_hessian(q);
    return m_potential.system();
  }
  void retract(State& q, const double* d, double scale) const override { m_potential.retract(q, d, scale); }

 private:
  Potential& m_potential;
  HostVectorOps m_ops;
};

}  // namespace

NewtonResult kinsol_minimise(Potential& potential, State& state, const NewtonSettings& settings,
                             double reference_force, LinearSolver& solver) {
  PotentialProblem problem(potential);
  return kinsol_solve(problem, state, settings, reference_force, solver);
}

}  // namespace fascia
