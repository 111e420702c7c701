#include "solve/linear_solver.hpp"

#include "solve/block_jacobi.hpp"
#include "solve/pcg.hpp"
#include "solve/sparse_cholesky.hpp"
#include "solve/vector_ops.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace fascia {

const char* to_string(LinearMethod method) {
  switch (method) {
    case LinearMethod::cg: return "cg";
    case LinearMethod::pcg: return "pcg";
    case LinearMethod::cholmod: return "cholmod";
  }
  return "?";
}

const char* to_string(Preconditioner preconditioner) {
  switch (preconditioner) {
    case Preconditioner::block_jacobi: return "block_jacobi";
    case Preconditioner::cholmod: return "cholmod";
  }
  return "?";
}

LinearMethod parse_linear_method(const std::string& name) {
  if (name == "cg") return LinearMethod::cg;
  if (name == "pcg") return LinearMethod::pcg;
  if (name == "cholmod") return LinearMethod::cholmod;
  throw std::invalid_argument("unknown linear method '" + name + "' (expected cg, pcg or cholmod)");
}

Preconditioner parse_preconditioner(const std::string& name) {
  if (name == "block_jacobi") return Preconditioner::block_jacobi;
  if (name == "cholmod") return Preconditioner::cholmod;
  throw std::invalid_argument("unknown preconditioner '" + name + "' (expected block_jacobi or cholmod)");
}

LinearSolver::LinearSolver() : m_cholesky(std::make_unique<SparseCholesky>()) {}
LinearSolver::~LinearSolver() = default;

LinearResult LinearSolver::factorise(const LinearSystem& system) {
  LinearResult r;
  r.factorised = true;
  if (!m_cholesky->factorise(system.assemble(), system.fixed)) {
    r.message = "CHOLMOD: tangent could not be factorised even with a diagonal shift";
    return r;
  }
  m_stale = false;
  r.converged = true;
  if (m_cholesky->shift() > 0) {
    r.shifted = true;
    std::ostringstream msg;
    msg << "CHOLMOD: tangent not positive definite, shifted by " << m_cholesky->shift() << " diag(H)";
    r.message = msg.str();
  }
  return r;
}

bool LinearSolver::reuses_factorisation() const { return !m_stale && m_cholesky->factorised(); }

bool LinearSolver::restore_factorisation(const LinearSystem& system) {
  m_stale = true;
  factorise(system);
  return m_cholesky->factorised();
}

LinearResult LinearSolver::solve(const LinearSystem& system, const LinearSettings& settings,
                                 const std::vector<double>& b, std::vector<double>& x) {
  const HostVectorOps ops(system.size, system.fixed);
  auto apply = [&](const std::vector<double>& p, std::vector<double>& out) { system.apply(p.data(), out.data()); };
  PcgSettings pcg_settings;
  pcg_settings.tolerance = settings.tolerance;
  pcg_settings.max_iterations = settings.max_iterations;
  pcg_settings.fixed_iterations = settings.fixed_iterations;

  if (settings.method == LinearMethod::cg)
    return pcg(ops, apply, IdentityPreconditioner<HostVectorOps>{ops}, pcg_settings, b, x);

  if (settings.method == LinearMethod::pcg && settings.preconditioner == Preconditioner::block_jacobi) {
    std::vector<double> blocks(36 * static_cast<size_t>(system.size / 6));
    system.diagonal_blocks(blocks.data());
    const BlockJacobi jacobi(std::move(blocks), system.fixed);
    return pcg(ops, apply, [&](const std::vector<double>& r, std::vector<double>& z) { jacobi.apply(r, z); },
               pcg_settings, b, x);
  }

  if (settings.method == LinearMethod::cholmod) {
    LinearResult r = factorise(system);
    if (!m_cholesky->factorised()) return r;
    std::vector<double> rhs = b;
    ops.project(rhs);
    m_cholesky->solve(rhs, x);
    std::vector<double> hx(x.size());
    apply(x, hx);
    ops.project(hx);
    ops.axpy(-1.0, rhs, hx);
    const double b_norm = ops.norm(rhs);
    r.relative_residual = b_norm > 0 ? ops.norm(hx) / b_norm : 0.0;
    return r;
  }

  // PCG preconditioned by the reused factorisation: refactorise when stale, and once more when
  // the reused one could not reach the tolerance within the cap.
  const bool was_stale = m_stale || !m_cholesky->factorised();
  LinearResult fresh;
  if (was_stale) {
    fresh = factorise(system);
    if (!m_cholesky->factorised()) return fresh;
  }
  auto precondition = [&](const std::vector<double>& r, std::vector<double>& z) { m_cholesky->solve(r, z); };
  LinearResult r = pcg(ops, apply, precondition, pcg_settings, b, x);
  if (!r.converged && !was_stale && !settings.fixed_iterations) {
    const int spent = r.iterations;
    fresh = factorise(system);
    if (!m_cholesky->factorised()) return fresh;
    r = pcg(ops, apply, precondition, pcg_settings, b, x);
    r.iterations += spent;
  }
  r.factorised = was_stale || fresh.factorised;
  r.shifted = fresh.shifted;
  if (r.iterations > settings.refactorise_above) m_stale = true;
  return r;
}

}  // namespace fascia
