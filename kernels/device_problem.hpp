// The device potential (device_potential.hpp) as a problem of the one Newton solver
// (engine/solve/newton.hpp): device vectors and states, the linear solve by the one PCG
// (engine/solve/pcg.hpp) with the device Hessian product, preconditioned by block Jacobi or by the
// factorisation of engine/solve/factorised_solve.hpp, the device Cholesky factor
// (device_cholesky.hpp): kept across solves (pcg with the cholmod preconditioner), or computed
// for each solve (the cholmod method: a factorisation per Newton iteration, as the CPU's direct
// solve, with PCG on that factor taking the solve to the linear tolerance, since the factor's
// inverse is applied in float). The same algorithm, settings and stopping rules as the CPU engine
// (solve/newton.cpp, HostPotentialProblem); the host reads only the scalars that steer the
// iterations. DeviceVariationalProblem (below) poses the variational step's equations the same
// way.
#pragma once

#include "device_cholesky.hpp"
#include "device_potential.hpp"
#include "device_variational.hpp"
#include "solve/factorised_solve.hpp"
#include "solve/newton.hpp"
#include "solve/pcg.hpp"

#include <functional>
#include <stdexcept>
#include <utility>

namespace fascia::gpu {

class DeviceProblem {
 public:
  using Ops = DeviceVectorOps;
  using Vector = DeviceVector;
  using State = DeviceFrames;

  // @param linear      the settings Newton solves with (NewtonSettings::linear)
  // @param factor      the device factor for the cholmod method and preconditioner, kept by the
  //                    caller between problems with its state `kept`
  //                    (solve/kept_factorisation.hpp); null: pcg is preconditioned by block Jacobi
  //                    whatever LinearSettings::preconditioner says, and the cholmod method is
  //                    refused.
  // @param factorising called with the iterate before each factorisation (may be empty)
  DeviceProblem(DevicePotential& potential, const LinearSettings& linear, DeviceCholesky* factor, KeptFactorisation& kept,
                std::function<void(const DeviceFrames&)> factorising = {})
      : m_potential(potential),
        m_ops(potential.ops(), potential.dofs(), potential.fixed()),
        m_factor(factor),
        m_kept(kept),
        m_factorising(std::move(factorising)) {
    if (linear.method == LinearMethod::cholmod && !factor)
      throw std::invalid_argument("the device step's cholmod method needs the device factor");
  }

  // Whether the settings want a factorisation of H: the cholmod method, or pcg with the cholmod
  // preconditioner.
  static bool factorises(const LinearSettings& linear) {
    return linear.method == LinearMethod::cholmod ||
           (linear.method == LinearMethod::pcg && linear.preconditioner == Preconditioner::cholmod);
  }

  const Ops& ops() const { return m_ops; }
  bool minimises() const { return true; }
  double value(const State& q) { return m_potential.value(q); }
  double gradient(const State& q, Vector& g) {
    m_ops.resize(g);
    const double phi = m_potential.gradient(q, g.data());
    m_ops.project(g);
    return phi;
  }
  LinearResult solve(const State& q, const Vector& rhs, Vector& d, const LinearSettings& linear) {
    const bool factored = m_factor && factorises(linear);  // else block Jacobi or none
    m_potential.prepare_hessian(q, !factored);
    auto apply = [this](const Vector& p, Vector& out) {
      m_ops.resize(out);
      m_potential.apply(p.data(), out.data());
    };
    if (factored) {
      struct Kept {
        DeviceProblem& problem;
        const State& q;
        LinearResult factorise() {
          if (problem.m_factorising) problem.m_factorising(q);
          return problem.m_factor->factorise(problem.m_potential);
        }
        bool factorised() const { return problem.m_factor->factorised(); }
        void solve(const Vector& r, Vector& z) const { problem.m_factor->solve(r.data(), z.data()); }
        bool shifted() const { return problem.m_factor->shift_step() >= 0; }
        bool stops_paying(const KeptFactorisation& k, int iterations) const {
          return fascia::stops_paying(k, iterations, problem.m_factor->cost());
        }
      } kept{*this, q};
      if (linear.method == LinearMethod::cholmod) m_kept.stale = true;  // a factorisation per solve
      return pcg_with_kept_factorisation(m_ops, apply, kept, m_kept, linear, rhs, d);
    }
    const PcgSettings pcg_settings = fascia::pcg_settings(linear);
    if (linear.method == LinearMethod::cg)
      return pcg(m_ops, apply, IdentityPreconditioner<Ops>{m_ops}, pcg_settings, rhs, d);
    const double* blocks = m_potential.preconditioner();
    const int frames = static_cast<int>(m_potential.dofs() / 6);
    auto precondition = [this, blocks, frames](const Vector& r, Vector& z) {
      m_ops.resize(z);
      m_ops.ops().block_apply(blocks, r.data(), z.data(), frames);
    };
    return pcg(m_ops, apply, precondition, pcg_settings, rhs, d);
  }
  void retract(State& q, const Vector& d, double alpha) { m_potential.retract(q, d.data(), alpha); }

 private:
  DevicePotential& m_potential;
  DeviceVectorOps m_ops;
  DeviceCholesky* m_factor;
  KeptFactorisation& m_kept;
  std::function<void(const DeviceFrames&)> m_factorising;
};

// The variational step's equations (4) (device_variational.hpp) as a problem of the one Newton
// solver, as VariationalProblem is on the CPU (integrate/variational_step.cpp): the residual r / h
// at q_{k+1}, which is not the gradient of a potential (a step must decrease |r|), and the
// iteration matrix 4 H, the potential's Hessian at the midpoint with the kinetic blocks, solved as
// DeviceProblem solves (the same preconditioners and kept factorisation) with the right-hand side
// times 4. `factorising` is called with q_{k+1} before each factorisation.
class DeviceVariationalProblem {
 public:
  using Ops = DeviceVectorOps;
  using Vector = DeviceVector;
  using State = DeviceFrames;

  DeviceVariationalProblem(DeviceVariational& step, DevicePotential& potential, const LinearSettings& linear,
                           DeviceCholesky* factor, KeptFactorisation& kept,
                           std::function<void(const DeviceFrames&)> factorising = {})
      : m_step(step),
        m_factorising(std::move(factorising)),
        m_linear(potential, linear, factor, kept, [this](const DeviceFrames&) {
          if (m_factorising) m_factorising(*m_end);
        }) {}
  DeviceVariationalProblem(const DeviceVariationalProblem&) = delete;
  DeviceVariationalProblem& operator=(const DeviceVariationalProblem&) = delete;

  const Ops& ops() const { return m_linear.ops(); }
  bool minimises() const { return false; }
  double value(const State&) { return 0; }
  double gradient(const State& end, Vector& r) {
    ops().resize(r);
    return m_step.residual(end, r.data());
  }
  LinearResult solve(const State& end, const Vector& rhs, Vector& d, const LinearSettings& linear) {
    m_end = &end;
    m_step.set_kinetic_blocks(end);
    ops().copy(rhs, m_rhs);
    ops().scale(4.0, m_rhs);
    return m_linear.solve(m_step.midpoint(end), m_rhs, d, linear);
  }
  void retract(State& q, const Vector& d, double alpha) { m_linear.retract(q, d, alpha); }

 private:
  DeviceVariational& m_step;
  std::function<void(const DeviceFrames&)> m_factorising;
  const DeviceFrames* m_end = nullptr;  // the iterate of the solve in progress
  DeviceProblem m_linear;               // the iteration matrix's solve
  Vector m_rhs;
};

}  // namespace fascia::gpu
