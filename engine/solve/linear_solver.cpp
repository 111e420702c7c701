#include "solve/linear_solver.hpp"

#include "solve/block_jacobi.hpp"
#include "solve/diagonal_shifts.hpp"
#include "solve/factorised_solve.hpp"
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
  r.converged = true;
  if (m_cholesky->shift() > 0) {
    r.shifted = true;
    std::ostringstream msg;
    msg << "CHOLMOD: tangent not positive definite, shifted by " << m_cholesky->shift() << " diag(H)";
    r.message = msg.str();
  }
  return r;
}

void LinearSolver::restore_shift(int shift_step) {
  m_cholesky->set_first_shift_step(resumed_first_shift_step(shift_step, false));
}

bool LinearSolver::reuses_factorisation() const { return !m_kept.stale && m_cholesky->factorised(); }

bool LinearSolver::restore_factorisation(const LinearSystem& system, const KeptFactorisation& served, int shift_step) {
  m_kept = KeptFactorisation{};
  m_cholesky->set_first_shift_step(resumed_first_shift_step(shift_step, true));
  factorise(system);
  if (!m_cholesky->factorised()) return false;
  m_kept = served;
  m_kept.stale = false;
  return true;
}

LinearResult LinearSolver::solve(const LinearSystem& system, const LinearSettings& settings,
                                 const std::vector<double>& b, std::vector<double>& x) {
  const HostVectorOps ops(system.size, system.fixed);
  auto apply = [&](const std::vector<double>& p, std::vector<double>& out) { system.apply(p.data(), out.data()); };
  const PcgSettings pcg_settings = fascia::pcg_settings(settings);

  if (settings.method == LinearMethod::cg)
    return pcg(ops, apply, IdentityPreconditioner<HostVectorOps>{ops}, pcg_settings, b, x);

  if (settings.method == LinearMethod::pcg && settings.preconditioner == Preconditioner::block_jacobi) {
    std::vector<double> blocks(36 * static_cast<size_t>(system.size / 6));
    system.diagonal_blocks(blocks.data());
    const BlockJacobi jacobi(std::move(blocks), system.fixed);
    return pcg(ops, apply, [&](const std::vector<double>& r, std::vector<double>& z) { jacobi.apply(r, z); },
               pcg_settings, b, x);
  }

  struct Kept {
    LinearSolver& solver;
    const LinearSystem& system;
    LinearResult factorise() { return solver.factorise(system); }
    bool factorised() const { return solver.m_cholesky->factorised(); }
    // Direct solves read the factor's own values; PCG's preconditioner may read them in float.
    void solve(const std::vector<double>& r, std::vector<double>& z) const {
      solver.m_cholesky->solve(r, z, preconditioner);
    }
    bool shifted() const { return solver.m_cholesky->shift() > 0; }
    bool stops_paying(const KeptFactorisation& k, int iterations) const {
      return fascia::stops_paying(k, iterations, kCholmodFactorisationCost);
    }
    bool preconditioner;
  } kept{*this, system, settings.method != LinearMethod::cholmod};
  if (settings.method == LinearMethod::cholmod) return direct_solve(ops, apply, kept, b, x);
  return pcg_with_kept_factorisation(ops, apply, kept, m_kept, settings, b, x);
}

}  // namespace fascia
