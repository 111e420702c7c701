#include "solve/newton.hpp"

#include <cmath>
#include <sstream>

namespace fascia {

double free_norm(const Model& model, const std::vector<double>& g) {
  double s = 0;
  for (size_t k = 0; k < g.size(); ++k)
    if (!model.fixed_dofs[k]) s += g[k] * g[k];
  return std::sqrt(s);
}

NewtonResult minimise(Potential& potential, State& state, const NewtonSettings& settings, double reference_force) {
  const Model& model = potential.model();
  const int n = model.dof_count();
  std::vector<double> g(n), d(n), rhs(n);
  NewtonResult result;
  double phi = potential.gradient(state, g);
  if (!std::isfinite(phi)) {
    result.message = "the starting state has non-finite energy (inverted element?)";
    return result;
  }
  const double g0 = free_norm(model, g);
  const double scale = std::max({reference_force, g0, 1e-300});
  const int iterations = settings.fixed_iterations > 0 ? settings.fixed_iterations : settings.max_iterations;
  for (int it = 0; it < iterations; ++it) {
    result.residual = free_norm(model, g) / scale;
    if (settings.fixed_iterations == 0 && result.residual <= settings.tolerance) {
      result.converged = true;
      break;
    }
    potential.prepare_hessian(state);
    for (int k = 0; k < n; ++k) rhs[k] = model.fixed_dofs[k] ? 0.0 : -g[k];
    const LinearResult lin = solve_linear(potential.system(), settings.linear, rhs, d);
    result.cg_iterations += lin.iterations;
    double slope = 0;
    for (int k = 0; k < n; ++k) slope += g[k] * d[k];
    if (!(slope < 0)) {  // not a descent direction: use steepest descent
      for (int k = 0; k < n; ++k) d[k] = rhs[k];
      slope = -free_norm(model, g) * free_norm(model, g);
    }
    ++result.iterations;
    if (settings.fixed_iterations > 0) {  // one linearised step per iteration, no line search
      potential.retract(state, d.data(), 1.0);
      phi = potential.gradient(state, g);
      continue;
    }
    // Backtracking line search with the Armijo condition on Phi.
    double alpha = 1.0;
    bool accepted = false;
    for (int b = 0; b <= settings.max_backtracks; ++b, alpha *= 0.5) {
      State trial = state;
      potential.retract(trial, d.data(), alpha);
      const double phi_trial = potential.value(trial);
      if (!std::isfinite(phi_trial)) continue;
      if (phi_trial <= phi + settings.armijo * alpha * slope) {
        state = std::move(trial);
        accepted = true;
        break;
      }
      // Near the minimum the predicted decrease falls below the round-off of Phi (a sum of
      // many terms): there, accept a step that reduces the gradient norm instead.
      if (std::abs(alpha * slope) <= 1e-10 * std::abs(phi) && std::abs(phi_trial - phi) <= 1e-10 * std::abs(phi)) {
        std::vector<double> g_trial;
        potential.gradient(trial, g_trial);
        if (free_norm(model, g_trial) < free_norm(model, g)) {
          state = std::move(trial);
          accepted = true;
          break;
        }
      }
    }
    if (!accepted) {
      // At round-off level the energy cannot decrease any further: accept if the residual is
      // already small, otherwise report.
      std::ostringstream msg;
      msg << "line search failed after " << settings.max_backtracks << " halvings at Newton iteration " << it + 1
          << " (relative residual " << result.residual << ")";
      result.message = msg.str();
      result.value = phi;
      return result;
    }
    phi = potential.gradient(state, g);
  }
  result.residual = free_norm(model, g) / scale;
  result.value = phi;
  if (settings.fixed_iterations > 0) {
    result.converged = std::isfinite(phi);
  } else if (!result.converged) {
    result.converged = result.residual <= settings.tolerance;
    if (!result.converged) {
      std::ostringstream msg;
      msg << "Newton did not converge in " << settings.max_iterations << " iterations (relative residual "
          << result.residual << ", tolerance " << settings.tolerance << ")";
      result.message = msg.str();
    }
  }
  return result;
}

}  // namespace fascia
