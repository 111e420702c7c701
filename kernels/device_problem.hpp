// The device potential (device_potential.hpp) as a problem of the one Newton solver
// (engine/solve/newton.hpp): device vectors and states, the linear solve by the one PCG
// (engine/solve/pcg.hpp) with the device Hessian product and block-Jacobi preconditioner. The
// same algorithm, settings and stopping rules as the CPU engine (solve/newton.cpp,
// HostPotentialProblem); the host reads only the scalars that steer the iterations.
#pragma once

#include "device_potential.hpp"
#include "solve/newton.hpp"
#include "solve/pcg.hpp"

#include <stdexcept>

namespace fascia::gpu {

class DeviceProblem {
 public:
  using Ops = DeviceVectorOps;
  using Vector = DeviceVector;
  using State = DeviceFrames;

  // The linear method must be cg or pcg; pcg is preconditioned by block Jacobi whatever
  // LinearSettings::preconditioner says (a sparse factorisation has no device counterpart).
  DeviceProblem(DevicePotential& potential, const LinearSettings& linear)
      : m_potential(potential), m_linear(linear), m_ops(potential.ops(), potential.dofs(), potential.fixed()) {
    if (!supported(linear)) throw std::invalid_argument("the device step solves with cg or pcg, not cholmod");
  }

  static bool supported(const LinearSettings& linear) { return linear.method != LinearMethod::cholmod; }

  const Ops& ops() const { return m_ops; }
  bool minimises() const { return true; }
  double value(const State& q) { return m_potential.value(q); }
  double gradient(const State& q, Vector& g) {
    m_ops.resize(g);
    const double phi = m_potential.gradient(q, g.data());
    m_ops.project(g);
    return phi;
  }
  LinearResult solve(const State& q, const Vector& rhs, Vector& d) {
    m_potential.prepare_hessian(q);
    PcgSettings pcg_settings;
    pcg_settings.tolerance = m_linear.tolerance;
    pcg_settings.max_iterations = m_linear.max_iterations;
    pcg_settings.fixed_iterations = m_linear.fixed_iterations;
    auto apply = [this](const Vector& p, Vector& out) {
      m_ops.resize(out);
      m_potential.apply(p.data(), out.data());
    };
    if (m_linear.method == LinearMethod::cg)
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
  const LinearSettings& m_linear;
  DeviceVectorOps m_ops;
};

}  // namespace fascia::gpu
