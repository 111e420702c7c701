// A variational (discrete Lagrangian) time step that conserves the linear and angular momentum of
// a free system exactly, up to the tolerance of its nonlinear solve (discrete Noether theorem;
// Marsden & West, "Discrete mechanics and variational integrators", Acta Numerica 2001, §1.3,
// §3.2; Lee, Leok & McClamroch, "Lie group variational integrators for the full body problem",
// CMAME 196, 2007, eq. (17)-(20) for the rotational kinetic term).
//
// Configuration q = every frame's (x_i, R_i); frames attached to rigid bodies are functions of
// their body (mechanics/rigid_mapping.hpp), so the unknowns are the reduced configuration. Each
// frame is a lumped rigid body: mass m_i at x_i, body inertia J_i (Model::frame_inertias: about the
// frame origin in rest axes, which are the body axes since rest orientations are identity).
//
// Discrete action of one step of size h from q_k to q_{k+1} (J s):
//   S(q_k, q_{k+1}) = sum_i [ m_i |x_{i,k+1} - x_{i,k}|^2 / (2h) + tr((I - F_i) Jd_i) / h ]
//                     - h V(q_mid)                                                        (1)
//   F_i  = R_{i,k}^T R_{i,k+1}         relative rotation in body axes
//   Jd_i = tr(J_i)/2 I - J_i           non-standard inertia (Lee et al. eq. (6)): for
//                                      F = exp([phi]x), tr((I - F) Jd) = phi^T J phi / 2 + O(phi^4)
//   V    = elastic energy of every object + load potential (StepPotential in static mode)
//   q_mid: x_mid = (x_k + x_{k+1}) / 2,  R_mid = exp(psi/2) R_k,  psi = log(R_{k+1} R_k^T)
//          (the geodesic midpoint), attached frames mapped from their body's midpoint.
// Every term is invariant under a global rigid motion (x -> Q x + t, R -> Q R): the kinetic terms
// see only x differences and F, the midpoint is equivariant (psi -> Q psi), and V is invariant.
//
// Derivatives (world-axis increments: x <- x + u, R <- exp([w]x) R, as everywhere in fascia):
//   translation:  dS/dx_{k+1} = m dx/h - (h/2) g_x,   dS/dx_k = -m dx/h - (h/2) g_x
//   rotation, kinetic part: with C = F Jd and vee([a]x) = a,
//                 dS/dw_{k+1} = kappa,  dS/dw_k = -kappa,  kappa = R_k vee(C - C^T) / h      (2)
//                 (perturbing R_{k+1} turns F into exp([R_k^T w]x) F; tr([a]x A) = -a.vee(A - A^T))
//   rotation, potential part: the midpoint's increment is theta = A w_{k+1} + B w_k with
//                 A = J_l(psi/2) J_l^{-1}(psi) / 2,                                       (3)
//                 B = exp([psi/2]x) - J_l(psi/2) J_r^{-1}(psi) / 2,  A + B = I
//                 (from log(exp(w) exp(psi)) = psi + J_l^{-1}(psi) w, log(exp(psi) exp(-w)) =
//                 psi - J_r^{-1}(psi) w, exp(a + e) = exp(J_l(a) e) exp(a); J_r(psi) = J_l(-psi)),
//                 so dS/dw_{k+1} = -h A^T tau,  dS/dw_k = -h B^T tau, tau = dV/dtheta at q_mid.
// For a body carrying attached frames the derivatives of their terms are reduced with J_a^T of
// the rigid mapping at the configuration they are taken at (q_k or q_{k+1}); the potential's
// reduced gradient at q_mid already carries the mapping at q_mid.
//
// Discrete Euler-Lagrange equations in position-momentum form (Marsden & West eq. (1.5.6)):
//   p_k = -D_1 S(q_k, q_{k+1})      solved for q_{k+1}                                       (4)
//   p_{k+1} = D_2 S(q_k, q_{k+1})                                                            (5)
// with p the reduced momenta (reduced frames [N][6]: linear N s, angular about the frame origin
// in world axes N m s). Discrete Noether: for an invariant S, J(q, p) = (sum p_x,
// sum x x p_x + p_r) satisfies J(q_{k+1}, p_{k+1}) = J(q_k, p_k + r) where r is the residual left
// in (4); |J change| <= sqrt(N) (max |x| + 1 m) |r| per step, and r -> 0 with the Newton tolerance.
// Velocities are stored as v = M(q)^{-1} p with the lumped mass matrix of the reduced frames
// (J^T M J for a body and its attached frames), so the momenta measured from velocities,
// sum m v and sum x x m v + R J R^T w, are exactly the discrete momenta J(q, p).
//
// Solve of (4): newton() (solve/newton.hpp) on the residual r(q_{k+1}) in force units r/h, with the
// symmetric approximation H = M_kin / h^2 + K(q_mid) / 4 of its Jacobian (M_kin: the symmetric part
// of the kinetic Jacobian, exact for translations, R_k sym(tr(C) I - C) R_k^T / h for rotations;
// K: the reduced tangent of V at the midpoint), solved by the configured CG/PCG/CHOLMOD. The
// omitted parts are O(|psi|) and O(h^2 |tau|) relative to H, so the iterations converge linearly
// at that rate (a few iterations for rotations of a few degrees per step); a step that does not
// reduce |r| is halved, and from an iteration whose halvings all fail Newton takes Newton-Krylov
// directions preconditioned by this solve (solve/newton.hpp). The converged q_{k+1} does not
// depend on the approximation. A step backend
// (step_backend.hpp) solves (4) and evaluates (5) where its data lives, with the same per-frame
// terms (discrete_action.hpp) and the same Newton.
//
// No damping: a variational step conserves momenta and keeps the energy oscillating about its
// initial value (backward Euler dissipates); Rayleigh damping is refused by Simulation.
#pragma once

#include "integrate/step_backend.hpp"
#include "integrate/step_potential.hpp"
#include "mechanics/rigid_mapping.hpp"
#include "solve/newton.hpp"

#include <vector>

namespace fascia {

class VariationalStep {
 public:
  // potential: V (set to static mode here, shared with the caller); dt: the step h in s.
  VariationalStep(const Model& model, StepPotential& potential, double dt);

  // One step: end enters as q_{k+1} with the fixed DOFs at their time t_{k+1} values (prescribed
  // motions applied, attached frames synced), leaves as the solution of (4) with velocities from
  // (5). start: q_k with velocities v_k. reference_force: the force scale of the relative residual
  // (N), as for minimise(); |p_k| / h and the first residual are used when larger.
  // The linear solves use `solver` (kept between steps; null: one for this step only); with a
  // `backend` the backend solves (4) and computes (5) (StepBackend::variational), and this step
  // keeps the momenta and velocities, which do not involve V.
  NewtonResult advance(const State& start, State& end, const NewtonSettings& settings, double reference_force,
                       LinearSolver* solver = nullptr, StepBackend* backend = nullptr);

  // Discrete action (1), J s. Both states synced.
  double action(const State& start, const State& end);
  // -D_1 S and D_2 S of (1), reduced [N][6] (zero on attached frames).
  void action_derivatives(const State& start, const State& end, std::vector<double>& minus_d1,
                          std::vector<double>& d2);
  // Reduced momenta J^T M v of a state from its velocities, [N][6].
  void momenta(const State& state, std::vector<double>& p);
  // Velocities v = M^{-1} p of the reduced frames (free DOFs; fixed DOFs move as end - start over
  // h), expanded to attached frames.
  void set_velocities(const State& start, State& end, const std::vector<double>& p);

  // r = -D_1 S - p_start of (4) at the free DOFs (zero elsewhere), N s; returns its norm.
  double residual(const State& start, const State& end, const std::vector<double>& p_start,
                  std::vector<double>& r);
  // The iteration matrix 4 H = 4 M_kin / h^2 + K(q_mid) at (start, end), N/m (see above): the
  // Jacobian of 4 r / h w.r.t. increments of q_{k+1} up to the omitted terms.
  LinearSystem iteration_matrix(const State& start, const State& end);
  // The inputs of the last iteration matrix assembled (tangent_origin.hpp).
  const TangentOrigin& assembled_at() const { return m_assembled_at; }

  // Free-DOF norm of the residual of (4) at the end of the last advance(), N s, and the force
  // scale its relative value was measured against (N; NewtonResult::scale: 0 where the predictor
  // was not admissible).
  double residual_norm() const { return m_residual_norm; }
  double residual_scale() const { return m_scale; }

 private:
  // Midpoint configuration q_mid (attached frames synced).
  void midpoint(const State& start, const State& end, State& mid) const;
  // Kinetic momenta kappa of every frame (translation m dx/h, rotation (2)), [N][6] world axes.
  void kinetic_momenta(const State& start, const State& end, std::vector<double>& kappa) const;
  // A_i^T g and B_i^T g of (3) for every reduced frame.
  void midpoint_transposes(const State& start, const State& end, const std::vector<double>& g,
                           std::vector<double>& at_g, std::vector<double>& bt_g) const;
  // iteration_matrix() at the midpoint m_mid left by the last residual().
  LinearSystem approximate_jacobian(const State& start, const State& end);

  const Model& m_model;
  StepPotential& m_potential;
  double m_dt;
  RigidMapping m_start_mapping, m_end_mapping;  // J at q_k and at q_{k+1}
  std::vector<std::uint8_t> m_fixed;            // model.fixed_dofs plus the attached frames
  State m_mid;
  TangentOrigin m_assembled_at;
  std::vector<double> m_mass_blocks;            // [N][36] M_kin of the current system
  std::vector<double> m_expanded, m_scratch;
  double m_residual_norm = 0, m_scale = 0;
};

}  // namespace fascia
