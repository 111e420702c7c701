#include "device_newton.hpp"

#include "device_buffers.cuh"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <sstream>

namespace fascia::gpu {
namespace {

// Device vectors of the Newton iteration and its linear solve, [6N] each.
struct Workspace {
  explicit Workspace(long long n) {
    for (auto* v : {&g, &d, &rhs, &g_trial, &r, &z, &p, &hp}) v->resize(static_cast<size_t>(n));
  }
  DeviceBuffer<double> g, d, rhs, g_trial, r, z, p, hp;
};

// Solves H x = b on the free DOFs (b projected), as conjugate_gradient in
// engine/solve/linear_solver.cpp: stops at |r| <= tol |b| or after max_iterations (exactly that
// many with fixed_iterations); on non-positive curvature returns the current iterate (the
// preconditioned b when no step was taken).
LinearResult device_pcg(DevicePotential& pot, const LinearSettings& settings, Workspace& w, const double* b,
                        double* x) {
  VectorOps& ops = pot.ops();
  const long long n = pot.dofs();
  const int frames = static_cast<int>(n / 6);
  const std::uint8_t* fixed = pot.fixed();
  const double* minv = settings.method == LinearMethod::pcg ? pot.preconditioner() : nullptr;
  auto update = [&](double alpha) {
    return ops.cg_update(frames, alpha, w.p.data(), w.hp.data(), minv, fixed, x, w.r.data(), w.z.data());
  };
  LinearResult result;
  ops.fill(x, 0.0, n);
  ops.scale_project(1.0, b, fixed, w.r.data(), n);
  ops.fill(w.p.data(), 0.0, n);
  ops.fill(w.hp.data(), 0.0, n);
  // alpha = 0: r unchanged, z = P^{-1} r; r.r = |b|^2.
  auto [bb, rz] = update(0.0);
  const double b_norm = std::sqrt(bb);
  if (b_norm == 0) {
    result.converged = true;
    return result;
  }
  ops.copy(w.z.data(), w.p.data(), n);
  for (int k = 0; k < settings.max_iterations; ++k) {
    pot.apply(w.p.data(), w.hp.data());
    const double curvature = ops.dot(w.p.data(), w.hp.data(), n, fixed);
    if (!(curvature > 0)) {
      result.negative_curvature = true;
      if (k == 0) ops.copy(w.z.data(), x, n);  // preconditioned steepest descent
      result.iterations = k;
      result.relative_residual = std::sqrt(ops.dot(w.r.data(), w.r.data(), n)) / b_norm;
      result.message = "non-positive curvature in CG; step truncated";
      return result;
    }
    const double alpha = rz / curvature;
    const auto [rr, rz_new] = update(alpha);
    result.iterations = k + 1;
    result.relative_residual = std::sqrt(rr) / b_norm;
    if (!settings.fixed_iterations && result.relative_residual <= settings.tolerance) {
      result.converged = true;
      return result;
    }
    const double beta = rz_new / rz;
    rz = rz_new;
    ops.xpay(w.z.data(), beta, w.p.data(), n);  // p = z + beta p
  }
  result.converged = result.relative_residual <= settings.tolerance || settings.fixed_iterations;
  if (!result.converged) result.message = "CG reached its iteration cap";
  return result;
}

}  // namespace

NewtonResult minimise_on_device(DevicePotential& pot, const NewtonSettings& settings, double reference_force) {
  if (settings.linear.method == LinearMethod::cholmod)
    throw std::invalid_argument("the device step solves with cg or pcg, not cholmod");
  VectorOps& ops = pot.ops();
  const long long n = pot.dofs();
  const std::uint8_t* fixed = pot.fixed();
  constexpr int cur = DevicePotential::kCurrent, trial = DevicePotential::kTrial;
  Workspace w(n);
  auto free_norm = [&](const double* v) { return std::sqrt(ops.dot(v, v, n, fixed)); };
  NewtonResult result;
  double phi = pot.gradient(cur, w.g.data());
  if (!std::isfinite(phi)) {
    result.message = "the starting state has non-finite energy (inverted element?)";
    return result;
  }
  const double g0 = free_norm(w.g.data());
  const double scale = std::max({reference_force, g0, 1e-300});
  const int iterations = settings.fixed_iterations > 0 ? settings.fixed_iterations : settings.max_iterations;
  double g_norm = g0;
  for (int it = 0; it < iterations; ++it) {
    result.residual = g_norm / scale;
    if (settings.fixed_iterations == 0 && result.residual <= settings.tolerance) {
      result.converged = true;
      break;
    }
    pot.prepare_hessian(cur);
    ops.scale_project(-1.0, w.g.data(), fixed, w.rhs.data(), n);
    const LinearResult lin = device_pcg(pot, settings.linear, w, w.rhs.data(), w.d.data());
    result.cg_iterations += lin.iterations;
    double slope = ops.dot(w.g.data(), w.d.data(), n);
    if (!(slope < 0)) {  // not a descent direction: use steepest descent
      ops.copy(w.rhs.data(), w.d.data(), n);
      slope = -g_norm * g_norm;
    }
    ++result.iterations;
    if (settings.fixed_iterations > 0) {  // one linearised step per iteration, no line search
      pot.retract(cur, w.d.data(), 1.0, cur);
      phi = pot.gradient(cur, w.g.data());
      g_norm = free_norm(w.g.data());
      continue;
    }
    // Backtracking line search with the Armijo condition on Phi.
    double alpha = 1.0;
    bool accepted = false;
    for (int b = 0; b <= settings.max_backtracks; ++b, alpha *= 0.5) {
      pot.retract(cur, w.d.data(), alpha, trial);
      const double phi_trial = pot.value(trial);
      if (!std::isfinite(phi_trial)) continue;
      if (phi_trial <= phi + settings.armijo * alpha * slope) {
        accepted = true;
        break;
      }
      // Near the minimum the predicted decrease falls below the round-off of Phi (a sum of
      // many terms): there, accept a step that reduces the gradient norm instead.
      if (std::abs(alpha * slope) <= 1e-10 * std::abs(phi) && std::abs(phi_trial - phi) <= 1e-10 * std::abs(phi)) {
        pot.gradient(trial, w.g_trial.data());
        if (free_norm(w.g_trial.data()) < g_norm) {
          accepted = true;
          break;
        }
      }
    }
    if (!accepted) {
      std::ostringstream msg;
      msg << "line search failed after " << settings.max_backtracks << " halvings at Newton iteration " << it + 1
          << " (relative residual " << result.residual << ")";
      result.message = msg.str();
      result.value = phi;
      return result;
    }
    pot.retract(cur, w.d.data(), alpha, cur);  // the accepted trial, recomputed in place
    phi = pot.gradient(cur, w.g.data());
    g_norm = free_norm(w.g.data());
  }
  result.residual = g_norm / scale;
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

}  // namespace fascia::gpu
