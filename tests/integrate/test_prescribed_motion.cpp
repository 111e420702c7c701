// Prescribed motion (integrate/prescribed_motion.hpp): a rigid body turned about a pivot while
// translating carries its attached frames along exactly the same rigid motion.
#include "integrate/prescribed_motion.hpp"

#include "core/rotation.hpp"
#include "integrate/simulation.hpp"
#include "support/coupling_fixtures.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace fascia;
using namespace fascia::test;

TEST_CASE("prescribed rotation about a pivot: the body and its attached frames follow the rigid motion exactly",
          "[integrate][motion][rigid]") {
  const Model model = coupled_model();
  int body = -1;
  for (const ObjectInfo& o : model.objects)
    if (o.kind == ObjectKind::rigid) body = o.frames.front();
  REQUIRE(body >= 0);
  PrescribedMotion motion;
  motion.frames = {body};
  motion.velocity = Vec3{0.01, -0.02, 0.005};
  motion.rotates = true;
  motion.angular_velocity = Vec3{0.4, -0.3, 2.0};  // rad/s: 0.1 rad over the active 50 ms
  motion.pivot = Vec3{0.2, 0.0, -0.02};            // a corner of the plate (a joint)
  motion.start = 0.01;
  motion.end = 0.06;

  SimulationSettings settings;
  settings.dt = 0.01;
  settings.newton.tolerance = 1e-8;
  const Integrator integrator = GENERATE(Integrator::backward_euler, Integrator::variational);
  settings.integrator = integrator;
  ExternalLoads loads;
  loads.gravity = Vec3{0, 0, -9.81};
  Simulation sim(model, loads, settings, {motion});
  // The body's six DOFs are prescribed.
  for (int k = 0; k < 6; ++k) REQUIRE(sim.model().fixed_dofs[6 * body + k] == 1);

  std::vector<int> attached;
  for (int i = 0; i < model.frame_count(); ++i)
    if (model.rigid_parents[i] == body) attached.push_back(i);
  REQUIRE(attached.size() == 9);
  for (int step = 1; step <= 8; ++step) {  // before, during and after the active interval
    sim.step();
    const double a = std::clamp(sim.time(), motion.start, motion.end) - motion.start;
    const Quat q = quat_exp(a * motion.angular_velocity);
    const Mat3 Q = rotation_matrix(q);
    std::vector<int> moved = attached;
    moved.push_back(body);
    for (int f : moved) {
      const Vec3 x0 = load3(&model.frame_rest_positions[3 * f]);
      const Vec3 expected = motion.pivot + a * motion.velocity + Q * (x0 - motion.pivot);
      // Round-off: a dozen operations on O(0.2 m) values, each within 1.1e-16 relative: ~1e-15 m;
      // the 1e-14 m bound allows ten times that (a wrong pivot or order is > 1e-4 m here).
      INFO("step " << step << " frame " << f);
      REQUIRE(norm(load3(&sim.state().positions[3 * f]) - expected) <= 1e-14);
      const Quat r = load_quat(&sim.state().orientations[4 * f]);
      const double agree = std::abs(r.w * q.w + r.x * q.x + r.y * q.y + r.z * q.z);  // |cos(angle/2)|
      REQUIRE(agree == Approx(1.0).margin(1e-14));
    }
  }
  // Held after the end: the body no longer moves.
  for (int k = 0; k < 6; ++k) REQUIRE(std::abs(sim.state().velocities[6 * body + k]) <= 1e-12);
}

TEST_CASE("prescribed translation only leaves the frames' rotations free", "[integrate][motion]") {
  Model model = coupled_model();
  PrescribedMotion motion;
  motion.frames = {0, 1};
  motion.velocity = Vec3{0, 0, 0.1};
  fix_prescribed_dofs(model, {motion});
  for (int f : motion.frames)
    for (int k = 0; k < 6; ++k) REQUIRE(model.fixed_dofs[6 * f + k] == (k < 3 ? 1 : 0));
  State s = rest_state(model);
  apply_motions(model, {motion}, 0.5, s);
  for (int f : motion.frames) {
    REQUIRE(s.positions[3 * f + 2] == Approx(model.frame_rest_positions[3 * f + 2] + 0.05));
    REQUIRE(s.orientations[4 * f] == 1.0);
  }
}
