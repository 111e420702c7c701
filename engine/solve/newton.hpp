// Newton's method with a backtracking line search on a potential energy (DESIGN.md):
// minimise Phi(q) over the frame configurations, q_{k+1} = q_k (+) alpha d with H d = -g.
#pragma once

#include "model/state.hpp"
#include "solve/linear_solver.hpp"

#include <string>

namespace fascia {

// A potential on frame configurations with gradient and Hessian w.r.t. increments
// theta (DESIGN.md): Phi(q (+) theta), theta in [N][6].
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

struct NewtonResult {
  bool converged = false;
  int iterations = 0;
  int cg_iterations = 0;
  double residual = 0;   // |g_free| / reference force at the end
  double value = 0;      // Phi at the end
  std::string message;   // why it stopped, when not converged
};

// Minimises potential from state (updated in place). reference_force: the force scale for the
// relative residual (N), e.g. the norm of the external loads; the initial gradient norm is used
// when it is larger.
NewtonResult minimise(Potential& potential, State& state, const NewtonSettings& settings, double reference_force);

// Norm of g over the free DOFs.
double free_norm(const Model& model, const std::vector<double>& g);

}  // namespace fascia
