// The device potential (device_potential.hpp) as a problem of the one Newton solver
// (engine/solve/newton.hpp): device vectors and states, the linear solve by the one PCG
// (engine/solve/pcg.hpp) with the device Hessian product. The same algorithm, settings and
// stopping rules as the CPU engine (solve/newton.cpp, HostPotentialProblem); the host reads the
// scalars that steer the iterations.
//
// Preconditioners (solver.linear.preconditioner):
//   block_jacobi  the inverse 6x6 diagonal blocks of H, on the device
//   cholmod       the CPU's kept sparse factorisation (solve/linear_solver.hpp,
//                 ReusedFactorisation) with the same refresh rule: when stale, H is assembled by
//                 the CPU twin of the device potential (StepPotential at the device iterate, read
//                 back once) and factorised by CHOLMOD; each application reads r back, solves
//                 L L^T z = r on the host and writes z back (2 x 6N doubles across the bus per
//                 CG iteration). It takes the CPU's CG iteration counts, which block Jacobi
//                 multiplies by 10 to 60 on the shipped scenes (docs/gpu.md).
#pragma once

#include "device_potential.hpp"
#include "integrate/step_potential.hpp"
#include "solve/linear_solver.hpp"
#include "solve/newton.hpp"
#include "solve/pcg.hpp"
#include "solve/sparse_cholesky.hpp"

#include <stdexcept>

namespace fascia::gpu {

// The host side of the cholmod preconditioner: the CPU twin of the device potential that
// assembles H, the kept factorisation, and host copies of the iterate and of r and z. The owner
// sets the twin's step (set_static / set_dynamic) as it sets the device potential's.
struct HostFactorisation {
  HostFactorisation(const Model& model, const ExternalLoads& loads, int threads)
      : potential(model, loads, threads), iterate(rest_state(model)) {}
  StepPotential potential;
  SparseCholesky cholesky;
  ReusedFactorisation reuse;
  State iterate;
  std::vector<double> r, z;  // [6N]
};

class DeviceProblem {
 public:
  using Ops = DeviceVectorOps;
  using Vector = DeviceVector;
  using State = DeviceFrames;

  // The linear method must be cg or pcg; pcg with the cholmod preconditioner needs `host`.
  DeviceProblem(DevicePotential& potential, const LinearSettings& linear, HostFactorisation* host = nullptr)
      : m_potential(potential), m_linear(linear), m_host(host), m_ops(potential.ops(), potential.dofs(), potential.fixed()) {
    if (!supported(linear)) throw std::invalid_argument("the device step solves with cg or pcg, not cholmod");
    if (uses_host_factorisation(linear) && !host)
      throw std::invalid_argument("the cholmod preconditioner needs the host factorisation");
  }

  static bool uses_host_factorisation(const LinearSettings& linear) {
    return linear.method == LinearMethod::pcg && linear.preconditioner == Preconditioner::cholmod;
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
    auto apply = [this](const Vector& p, Vector& out) {
      m_ops.resize(out);
      m_potential.apply(p.data(), out.data());
    };
    if (m_linear.method == LinearMethod::cg)
      return pcg(m_ops, apply, IdentityPreconditioner<Ops>{m_ops}, pcg_settings(m_linear), rhs, d);
    if (m_host) return solve_host_factorisation(q, apply, rhs, d);
    const double* blocks = m_potential.preconditioner();
    const int frames = static_cast<int>(m_potential.dofs() / 6);
    auto precondition = [this, blocks, frames](const Vector& r, Vector& z) {
      m_ops.resize(z);
      m_ops.ops().block_apply(blocks, r.data(), z.data(), frames);
    };
    return pcg(m_ops, apply, precondition, pcg_settings(m_linear), rhs, d);
  }
  void retract(State& q, const Vector& d, double alpha) { m_potential.retract(q, d.data(), alpha); }

 private:
  template <class Apply>
  LinearResult solve_host_factorisation(const State& q, Apply& apply, const Vector& rhs, Vector& d) {
    HostFactorisation& host = *m_host;
    const cudaStream_t stream = m_ops.ops().stream();
    const size_t n = static_cast<size_t>(m_potential.dofs());
    host.r.resize(n);
    host.z.resize(n);
    auto factorise_at_q = [&] {
      q.download(host.iterate);
      host.potential.prepare_hessian(host.iterate);
      return factorise(host.cholesky, host.potential.system());
    };
    auto precondition = [&](const Vector& r, Vector& z) {
      m_ops.resize(z);
      FASCIA_CUDA(cudaMemcpyAsync(host.r.data(), r.data(), n * sizeof(double), cudaMemcpyDeviceToHost, stream));
      FASCIA_CUDA(cudaStreamSynchronize(stream));
      host.cholesky.solve(host.r, host.z);
      FASCIA_CUDA(cudaMemcpyAsync(z.data(), host.z.data(), n * sizeof(double), cudaMemcpyHostToDevice, stream));
    };
    return host.reuse.solve(m_ops, apply, factorise_at_q, precondition, m_linear, rhs, d);
  }

  DevicePotential& m_potential;
  const LinearSettings& m_linear;
  HostFactorisation* m_host;
  DeviceVectorOps m_ops;
};

}  // namespace fascia::gpu
