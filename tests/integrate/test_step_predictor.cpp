// The starting guesses of static and backward-Euler steps (integrate/step_predictor.hpp): the
// secant extrapolation of two equilibria related by a known rigid motion, the fixed DOFs it
// leaves alone, and the backward-Euler guess as the minimiser of the step's inertia and damping,
// with the last step's force acceleration held.
#include "integrate/step_potential.hpp"
#include "integrate/step_predictor.hpp"
#include "support/fixtures.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace fascia;
using fascia::test::random_state;
using fascia::test::small_box_model;

namespace {

// The rigid motion x -> Q x + t, R -> Q R of every frame of `s`.
State moved_rigidly(const State& s, const Quat& q, const Vec3& t) {
  State out = s;
  const Mat3 Q = rotation_matrix(q);
  for (int i = 0; i < s.frame_count(); ++i) {
    store3(&out.positions[3 * i], Q * load3(&s.positions[3 * i]) + t);
    store_quat(&out.orientations[4 * i], normalized(q * load_quat(&s.orientations[4 * i])));
  }
  return out;
}

double angle_between(const Quat& a, const Quat& b) { return norm(quat_log(a * conjugate(b))); }

}  // namespace

TEST_CASE("static predictor: two equilibria related by a rigid motion give its continuation", "[integrate][predictor]") {
  // q_k = (Q, t) q_{k-1}. The orientations extrapolate exactly: psi_i = log(Q) for every frame,
  // so R_pred = exp(r log Q) R_k = Q^r R_k (r = h / h_old). The positions extrapolate linearly,
  // x_pred = x_k + r (x_k - x_{k-1}): exact for a translation (the continued motion moves by r t);
  // for a rotation the continued motion (ratio 1) is Q x_k + t, and
  //   x_pred - (Q x_k + t) = (I - Q)(x_k - x_{k-1}),  |I - Q| = 2 sin(theta / 2) <= theta,
  // a second-order error theta |x_k - x_{k-1}| the Newton iterations remove.
  const Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk, 2, 2, 1);
  const State previous = random_state(model, 3, 0.01, 0.5, 0.7);
  const double theta = GENERATE(0.0, 0.05, 0.8);
  const double ratio = GENERATE(0.5, 1.0, 2.0);
  const Vec3 axis = (1 / std::sqrt(14.0)) * Vec3{1, -2, 3};
  const Quat q = quat_exp(theta * axis);
  const Vec3 t{0.03, -0.01, 0.02};  // m
  const State current = moved_rigidly(previous, q, t);
  std::vector<double> d;
  extrapolated_increments(previous, current, ratio, d);
  State predicted = current;
  retract(model, predicted, d.data(), 1.0);
  const Quat q_r = quat_exp(ratio * theta * axis);
  for (int i = 0; i < model.frame_count(); ++i) {
    // Orientations: Q^r R_k to round-off (quaternion products and a log/exp pair, ~1e-15 rad).
    REQUIRE(angle_between(load_quat(&predicted.orientations[4 * i]), q_r * load_quat(&current.orientations[4 * i])) <=
            1e-12);
    const Vec3 x0 = load3(&previous.positions[3 * i]), x1 = load3(&current.positions[3 * i]);
    const Vec3 x = load3(&predicted.positions[3 * i]);
    REQUIRE(norm(x - (x1 + ratio * (x1 - x0))) <= 1e-15);
    if (ratio == 1.0) {
      const Vec3 continued = rotation_matrix(q) * x1 + t;
      REQUIRE(norm(x - continued) <= theta * norm(x1 - x0) + 1e-15);
      if (theta == 0.0) REQUIRE(norm(x - continued) <= 1e-15);
    }
  }
}

TEST_CASE("static predictor: moves the free DOFs only, and nothing without a history", "[integrate][predictor]") {
  Model model = small_box_model(CellType::hexahedron, MaterialLaw::stvk, 2, 1, 1);
  model.fixed_dofs.assign(model.dof_count(), 0);
  for (int k = 0; k < kFrameDofs; ++k) model.fixed_dofs[k] = 1;  // frame 0
  model.fixed_dofs[kFrameDofs + 2] = 1;                           // frame 1, z
  const State previous = random_state(model, 4, 0.01, 0.3);
  const State current = random_state(model, 5, 0.01, 0.3);
  State trial = random_state(model, 6, 0.01, 0.3);  // its fixed DOFs stand for the motions' values
  const State before = trial;
  predict_static_step(model, PathHistory{}, current, 0.1, trial);
  REQUIRE(trial.positions == before.positions);
  REQUIRE(trial.orientations == before.orientations);
  PathHistory history{previous, 0.2};
  predict_static_step(model, history, current, 0.1, trial);
  // Frame 0 entirely fixed: unchanged. Frame 1: z unchanged, x and y moved by r (x_k - x_{k-1}).
  for (int k = 0; k < 3; ++k) REQUIRE(trial.positions[k] == before.positions[k]);
  for (int k = 0; k < 4; ++k) REQUIRE(trial.orientations[k] == before.orientations[k]);
  REQUIRE(trial.positions[5] == before.positions[5]);
  for (int k = 3; k < 5; ++k)
    REQUIRE(trial.positions[k] == Approx(before.positions[k] + 0.5 * (current.positions[k] - previous.positions[k])));
}

TEST_CASE("backward-Euler predictor without a history: the minimiser of the step's inertia and mass damping",
          "[integrate][predictor]") {
  // A free body translating rigidly at velocity v from rest shape, no loads: W and its gradient
  // vanish along the translation, and Phi's inertia and damping terms are least at
  // Delta = h v / (1 + alpha h) for every frame, so the gradient of Phi at the prediction is
  // round-off (relative to its value at the unpredicted guess q_k, m |v| / h per frame).
  const Model model = small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 2, 1, 1);
  const ExternalLoads loads;
  StepPotential potential(model, loads);
  State start = rest_state(model);
  const Vec3 v{0.3, -0.2, 0.5};  // m/s
  for (int i = 0; i < model.frame_count(); ++i) store3(&start.velocities[6 * i], v);
  const double h = 0.02;
  const double alpha = GENERATE(0.0, 10.0, 200.0);  // 1/s
  potential.set_dynamic(start, h, alpha, 0.0);
  std::vector<double> g0, g;
  potential.gradient(start, g0);
  State predicted = start;
  predict_dynamic_step(model, PathHistory{}, start, h, alpha, predicted);
  for (int i = 0; i < model.frame_count(); ++i)
    REQUIRE(norm(load3(&predicted.positions[3 * i]) - load3(&start.positions[3 * i]) - (h / (1 + alpha * h)) * v) <=
            1e-15);
  potential.gradient(predicted, g);
  double n0 = 0, n = 0;
  for (size_t k = 0; k < g.size(); ++k) n0 += g0[k] * g0[k], n += g[k] * g[k];
  REQUIRE(std::sqrt(n) <= 1e-9 * std::sqrt(n0));
}

TEST_CASE("backward-Euler predictor: under forces constant along the motion the guess is the step's minimiser",
          "[integrate][predictor]") {
  // A free body moving rigidly (W and its gradient vanish along translations) under point forces
  // f_i = m_i a on its frames: V's gradient is -m_i a whatever the state, so the last step's force
  // acceleration holds over the next one. The last step (h_old, v_{k-1} -> v_k) is backward
  // Euler's own: (1 + alpha h_old) v_k = v_{k-1} + h_old a. The guess for a step of h != h_old must
  // make Phi's gradient round-off relative to its value at the guess without a history
  // (m |h a| / h per frame: the forces this term predicts).
  const Model model = small_box_model(CellType::tetrahedron, MaterialLaw::neo_hookean, 2, 1, 1);
  const Vec3 a{0.4, -1.5, -9.81};       // m/s^2
  const Vec3 v_previous{0.3, -0.2, 0.5};  // m/s
  ExternalLoads loads;
  for (int i = 0; i < model.frame_count(); ++i) loads.point_forces.push_back({i, model.frame_masses[i] * a});
  StepPotential potential(model, loads);
  const double h_old = 0.02, h = GENERATE(0.02, 0.03, 0.005);
  const double alpha = GENERATE(0.0, 10.0);  // 1/s
  const Vec3 v = (1 / (1 + alpha * h_old)) * (v_previous + h_old * a);
  PathHistory history;
  history.previous = rest_state(model);
  history.dt = h_old;
  State current = rest_state(model);
  for (int i = 0; i < model.frame_count(); ++i) {
    store3(&history.previous.velocities[6 * i], v_previous);
    store3(&current.positions[3 * i], load3(&current.positions[3 * i]) + h_old * v);
    store3(&current.velocities[6 * i], v);
  }
  potential.set_dynamic(current, h, alpha, 0.0);
  State unaccelerated = current, predicted = current;
  predict_dynamic_step(model, PathHistory{}, current, h, alpha, unaccelerated);
  predict_dynamic_step(model, history, current, h, alpha, predicted);
  const Vec3 step = (h / (1 + alpha * h)) * (v + h * a);
  for (int i = 0; i < model.frame_count(); ++i)
    REQUIRE(norm(load3(&predicted.positions[3 * i]) - load3(&current.positions[3 * i]) - step) <= 1e-15);
  std::vector<double> g0, g;
  potential.gradient(unaccelerated, g0);
  potential.gradient(predicted, g);
  double n0 = 0, n = 0;
  for (size_t k = 0; k < g.size(); ++k) n0 += g0[k] * g0[k], n += g[k] * g[k];
  REQUIRE(n0 > 0);
  REQUIRE(std::sqrt(n) <= 1e-9 * std::sqrt(n0));
}
