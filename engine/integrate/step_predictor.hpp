// The starting guess of a static step along a load path: the free frames extrapolated from the
// last two accepted equilibria q_{k-1} (at t_{k-1}) and q_k (at t_k = t_{k-1} + h_old) to
// t_k + h, with r = h / h_old:
//
//   x_i <- x_{i,k} + r (x_{i,k} - x_{i,k-1})                                    (m)
//   R_i <- exp(r [psi_i]x) R_{i,k},   psi_i = log(R_{i,k} R_{i,k-1}^T)          (world axes)
//
// the secant predictor of path following (Crisfield, Non-linear Finite Element Analysis of
// Solids and Structures, vol. 1, §9.4; Allgower & Georg, Numerical Continuation Methods, §2.2).
// On a smooth path q*(t) its error is O(h (h + h_old)) where the guess q_k alone is O(h) away:
// each step's Newton starts in the neighbourhood the motion of the prescribed frames alone would
// leave (elements next to a moving tool compressed by the whole increment). The rotation part is
// exact for frames turning at a constant rate about a fixed axis (exp(r psi) R_k with
// psi = log(Q) gives Q^r R_k); the positions are exact for translations at a constant rate.
//
// Backward Euler: its guess is the minimiser of the step's inertia and mass-damping terms, with
// the forces taken as those of the last step (step_potential.hpp's Phi with W + V linearised as a
// constant force f). The step from q_k satisfies M (Delta - h v_k) / h^2 + alpha M Delta / h = -f,
// so with the force acceleration a = -M^{-1} f
//
//   Delta = h (v_k + h a) / (1 + alpha h)
//
// and the last step (h_old, from v_{k-1} to v_k) gives a = ((1 + alpha h_old) v_k - v_{k-1}) / h_old
// exactly for that step's forces. Holding a over the next step is the secant extrapolation of the
// velocities: its error is O(h h_old) in the velocities, O(h^2 h_old) in Delta, where the guess
// without a (the free motion of a damped mass, h v_k / (1 + alpha h)) is O(h^2) away. Under
// constant forces (a uniform fall, a held load on a body moving rigidly) the guess is the step's
// minimiser. Without a history (the first step, or after a restore without one) a = 0.
#pragma once

#include "model/model.hpp"
#include "model/state.hpp"

#include <vector>

namespace fascia {

// What the predictor keeps from one step to the next (a checkpoint keeps it): the accepted state
// before the current one (static steps: an equilibrium; backward Euler: its velocities too) and
// the step h_old from it to the current one.
struct PathHistory {
  State previous;   // q_{k-1}; empty: none (the first step, or after a restore without one)
  double dt = 0;    // h_old (s of pseudo-time); 0: none
  bool held() const { return dt > 0 && !previous.positions.empty(); }
};

// The increments d [N][6] (translation m, rotation vector rad, world axes) that take `current`
// (q_k) to the extrapolation above with ratio r = h / h_old, for every frame.
void extrapolated_increments(const State& previous, const State& current, double ratio, std::vector<double>& d);

// Moves the free DOFs of `trial` (model.fixed_dofs clear; no rotation where the model locks
// rotations, as retract()) by extrapolated_increments(history.previous, current, h / history.dt);
// fixed DOFs keep their values. Frames attached to rigid bodies must be synced by the caller.
// No change without a history.
void predict_static_step(const Model& model, const PathHistory& history, const State& current, double h, State& trial);

// Backward Euler: moves the free DOFs of `trial` by Delta = h (v + h a) / (1 + rayleigh_mass h)
// (above), v the velocities of `current` (m/s, rad/s world axes), a from history.previous's
// velocities and history.dt (a = 0 without a history), h in s, rayleigh_mass alpha in 1/s. Fixed
// DOFs keep their values; attached frames must be synced by the caller.
void predict_dynamic_step(const Model& model, const PathHistory& history, const State& current, double h,
                          double rayleigh_mass, State& trial);

}  // namespace fascia
