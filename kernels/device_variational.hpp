// The variational step's discrete Euler-Lagrange equations (engine/integrate/variational_step.hpp,
// (4) and (5)) on the device: the residual, the iteration matrix and the end momenta over device
// arrays, with the per-frame bodies of integrate/discrete_action.hpp and V evaluated by the device
// potential in static mode (device_potential.hpp) at the geodesic midpoint. The kinetic momenta are
// reduced by the rigid mapping at the configuration they are taken at (q_k or q_{k+1}: two
// DeviceRigidMapping besides the potential's, which reduces V at q_mid), as the CPU step does.
// DeviceVariationalProblem (device_problem.hpp) hands them to the one Newton solver.
#pragma once

#include "device_frames.hpp"
#include "device_potential.hpp"
#include "device_rigid.hpp"

#include <vector>

namespace fascia::gpu {

class DeviceVariational {
 public:
  // potential: V (kept in static mode by the caller: set_static); dt: the step h (s).
  DeviceVariational(DevicePotential& potential, double dt);

  double dt() const { return m_dt; }
  // The step's start q_k (positions, orientations) and its reduced momenta p_k [N][6] (N s; may
  // be empty where only the iteration matrix is wanted).
  void set_start(const State& start, const std::vector<double>& p_start);
  // q_mid of (q_k, end), attached frames synced.
  const DeviceFrames& midpoint(const DeviceFrames& end);
  // r / h (N) of (4), r = -D_1 S - p_k, at end into r [6N] (fixed DOFs zero); returns V(q_mid)
  // (non-finite where q_mid is not admissible).
  double residual(const DeviceFrames& end, double* r);
  // Sets the potential's frame blocks to 4 M_kin / h^2 at (q_k, end), reduced by the mapping at
  // end: with the potential prepared at midpoint(end), its Hessian is the iteration matrix 4 H.
  void set_kinetic_blocks(const DeviceFrames& end);
  // D_2 S of (5) at end into p_end [N][6] (host).
  void end_momenta(const DeviceFrames& end, std::vector<double>& p_end);

 private:
  // kappa of every frame (discrete_action.hpp) into out [N][6], reduced by `mapping` at its state.
  void kinetic_momenta(const DeviceFrames& end, const DeviceRigidMapping& mapping, double* out);

  DevicePotential& m_potential;
  double m_dt;
  DeviceRigidMapping m_start_mapping, m_end_mapping;
  DeviceFrames m_start, m_mid;
  DeviceBuffer<double> m_masses, m_inertias;  // [N], [N][9] body inertias
  DeviceBuffer<double> m_p_start, m_g, m_d2, m_kinetic_blocks;  // [N][6] each, [N][36]
};

}  // namespace fascia::gpu
