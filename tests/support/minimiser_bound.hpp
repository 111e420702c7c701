// How far apart two runs of one Newton solve may end when they differ only in round-off (e.g. the
// CPU and CUDA backends of the volumetric elasticity, which sum in different orders).
//
// Derivation. Both runs minimise the same potential Phi (StepPotential) and stop where
// |g_free(q)| <= tau F. Near the exact minimiser q*, Phi is strongly convex with modulus lambda,
// the smallest eigenvalue of the free block of its Hessian H (Newton's last iterates lie in that
// quadratic region), so |q - q*| <= |g_free(q)| / lambda for each run and
//   |q_a - q_b| <= (|g_free(q_a)| + |g_free(q_b)|) / lambda
// in the Euclidean norm of the free increments [dx (m), dr (rad)]. lambda is evaluated at q_a,
// not at q*; the Hessian varies by O(|q_a - q*|) over that tiny ball, which the factor 2 in
// `distance` covers. Both gradients are evaluated here by one CPU StepPotential, so the bound
// does not trust the backend under test. Frames mapped to rigid bodies follow their body:
// |dx_i| <= |dx_b| + |r_i - r_b| |dr_b|, bounded with the model's extent.
#pragma once

#include "core/rotation.hpp"
#include "integrate/step_potential.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseCore>

#include <algorithm>
#include <cmath>
#include <vector>

namespace fascia::test {

struct MinimiserBound {
  double gradient_a = 0, gradient_b = 0;  // |g_free| at each state (N, N m mixed)
  double lambda_min = 0;                  // smallest eigenvalue of the free Hessian at a
  double distance = 0;                    // bound on |q_a - q_b| over the free increments
  double extent = 0;                      // diagonal of the frames' bounding box (m)
};

// |g_free| of potential at state (free: the reduced system's unfixed DOFs).
inline double free_gradient_norm(StepPotential& potential, const State& state) {
  std::vector<double> g;
  potential.gradient(state, g);
  const LinearSystem sys = potential.system();
  double s = 0;
  for (int k = 0; k < sys.size; ++k)
    if (!sys.fixed[k]) s += g[k] * g[k];
  return std::sqrt(s);
}

// The potential must be set up (set_equilibrium / set_dynamic) as in the runs that produced a and b.
inline MinimiserBound minimiser_bound(StepPotential& potential, const State& a, const State& b) {
  MinimiserBound r;
  r.gradient_a = free_gradient_norm(potential, a);
  r.gradient_b = free_gradient_norm(potential, b);
  potential.prepare_hessian(a);
  const LinearSystem sys = potential.system();
  const Eigen::MatrixXd H = Eigen::MatrixXd(sys.assemble());
  std::vector<int> free;
  for (int k = 0; k < sys.size; ++k)
    if (!sys.fixed[k]) free.push_back(k);
  Eigen::MatrixXd Hf(free.size(), free.size());
  for (size_t i = 0; i < free.size(); ++i)
    for (size_t j = 0; j < free.size(); ++j) Hf(i, j) = H(free[i], free[j]);
  r.lambda_min = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(Hf, Eigen::EigenvaluesOnly).eigenvalues().minCoeff();
  r.distance = 2 * (r.gradient_a + r.gradient_b) / r.lambda_min;
  const Model& model = potential.model();
  Vec3 lo{HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi{-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (int i = 0; i < model.frame_count(); ++i) {
    const Vec3 x = load3(&a.positions[3 * i]);
    lo = Vec3{std::min(lo.x, x.x), std::min(lo.y, x.y), std::min(lo.z, x.z)};
    hi = Vec3{std::max(hi.x, x.x), std::max(hi.y, x.y), std::max(hi.z, x.z)};
  }
  r.extent = norm(hi - lo);
  return r;
}

// Largest differences between two states: frame positions (m), rotations (rad, |log(R_a R_b^T)|)
// and velocities (translational m/s and angular rad/s, mixed as in State::velocities).
struct StateDifference {
  double position = 0, rotation = 0, velocity = 0;
};

inline StateDifference max_difference(const State& a, const State& b) {
  StateDifference d;
  for (int i = 0; i < a.frame_count(); ++i) {
    d.position = std::max(d.position, norm(load3(&a.positions[3 * i]) - load3(&b.positions[3 * i])));
    const Quat rel = load_quat(&a.orientations[4 * i]) * conjugate(load_quat(&b.orientations[4 * i]));
    d.rotation = std::max(d.rotation, norm(quat_log(rel)));
    for (int k = 0; k < 6; ++k)
      d.velocity = std::max(d.velocity, std::abs(a.velocities[6 * i + k] - b.velocities[6 * i + k]));
  }
  return d;
}

}  // namespace fascia::test
