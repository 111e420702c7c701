// A simulation: a model, its loads, prescribed motions and an integrator advanced step by step.
// This is what `fascia run` drives; each step reports what the HDF5 observables record.
#pragma once

#include "integrate/prescribed_motion.hpp"
#include "integrate/step_backend.hpp"
#include "integrate/step_error.hpp"
#include "integrate/step_predictor.hpp"
#include "integrate/tangent_origin.hpp"
#include "mechanics/external_loads.hpp"
#include "mechanics/volumetric_elasticity.hpp"
#include "model/model.hpp"
#include "model/state.hpp"
#include "solve/newton.hpp"

#include <chrono>
#include <memory>
#include <string>
#include <vector>

namespace fascia {

// static: equilibrium under the loads; backward_euler: the incremental potential (dissipative,
// step_potential.hpp); variational: the midpoint discrete Lagrangian, which conserves linear and
// angular momentum of a free system and does not dissipate (variational_step.hpp).
enum class Integrator { static_equilibrium, backward_euler, variational };

const char* to_string(Integrator integrator);
Integrator parse_integrator(const std::string& name);  // "static" | "backward_euler" | "variational"

struct SimulationSettings {
  Integrator integrator = Integrator::backward_euler;
  double dt = 0.01;                 // s (dynamic); static: pseudo-time per load step
  double rayleigh_mass = 0;         // alpha, 1/s:   damping D = alpha M + beta K (backward Euler only)
  double rayleigh_stiffness = 0;    // beta,  s
  int load_steps = 1;               // static: initial number of load increments
  int max_load_halvings = 10;       // static: smallest load increment = the first / 2^this
  int threads = 0;                  // 0 = all
  AdaptiveSettings adaptive;        // backward Euler, static: adaptive steps (advance_to()), dt the first
  NewtonSettings newton;
  // Backend of the volumetric elasticity (mechanics/volumetric_elasticity.hpp); empty: the CPU
  // Elasticity. kernels/cuda_elasticity.hpp makes the CUDA one.
  ElasticityFactory elasticity;
  // Backend of the whole step (step_backend.hpp); empty, or where it does not cover the model:
  // the CPU engine (with `elasticity`). kernels/cuda_step.hpp makes the CUDA one.
  StepBackendFactory step_backend;
};

struct StepReport {
  int step = 0;
  double time = 0;                  // s, after the step
  bool converged = false;
  int newton_iterations = 0;
  int cg_iterations = 0;
  double residual = 0;              // relative, see NewtonResult
  double elastic_energy = 0;        // J
  double kinetic_energy = 0;        // J
  double external_potential = 0;    // J (gravity and point forces)
  double wall_seconds = 0;
  double dt = 0;                    // s, the last accepted step's size
  int accepted_steps = 0;           // steps accepted by this call (step(): 1)
  int rejected_steps = 0;           // attempts rejected by this call (adaptive only)
  std::string message;
};

class Simulation {
 public:
  Simulation(Model model, ExternalLoads loads, SimulationSettings settings,
             std::vector<PrescribedMotion> motions = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // One step: a backward-Euler or variational time step, or for static equilibrium a full solve with load
  // stepping (repeated static steps follow prescribed motions in pseudo-time dt). Throws
  // SolverError when Newton fails or the state becomes non-finite; the state is then left at
  // the last converged step. A stop request (core/stop_request.hpp) abandons the step with
  // StopRequested, leaving the state at the last completed step likewise.
  StepReport step();

  // Adaptive backward Euler or statics (settings().adaptive.enabled): steps from time() to exactly t_target
  // (s), each accepted or rejected and retried by the step controller (step_controller.hpp). The
  // report sums the Newton and CG iterations of all attempts and counts the accepted and
  // rejected steps. Throws SolverError when a step fails at min_dt; the state is then left at
  // the last accepted step.
  StepReport advance_to(double t_target);
  // The attempts of the advance_to() in progress, after the last completed attempt (zero after
  // advance_to() returns); restore_progress() sets them on a resumed simulation, whose next
  // advance_to() adds its attempts to them.
  const AdvanceProgress& advance_progress() const { return m_progress; }
  void restore_progress(const AdvanceProgress& progress) { m_progress = progress; }
  // The controller's state (checkpoints); null unless adaptive.
  const StepController* controller() const { return m_controller.get(); }
  StepController* controller() { return m_controller.get(); }
  // Continues from a saved state: after restore(state, k, t) the next step() computes step k + 1
  // exactly as an uninterrupted simulation would (the state, step count and time are all a step
  // depends on; io/checkpoint.hpp saves them).
  void restore(const State& state, int step, double time);
  // The accepted state before the current one, from which the next step's starting guess is
  // extrapolated (step_predictor.hpp): static steps from their second on, backward Euler from its
  // first; empty for the variational integrator. restore() clears it; restore_path_history() sets
  // it after restore().
  const PathHistory& path_history() const { return m_history; }
  void restore_path_history(const PathHistory& history);
  // PCG's reused CHOLMOD factorisation (solver.linear: pcg + cholmod on the CPU engine) as it
  // stands after the last completed step or attempt: a step abandoned on a stop does not change
  // it. A checkpoint keeps it with the state.
  const ReusedTangent& reused_tangent() const { return m_reused; }
  // After restore(): assembles the tangent at `tangent`'s origin and factorises it as the one
  // the next step reuses, so that the steps continue bitwise as the saved run's would have.
  // Returns false where they may not: the factorisation failed, or its sparsity analysis differs
  // from the saved one (an entry of the pattern the saved run analysed is exactly zero here).
  bool restore_tangent(const ReusedTangent& tangent);

  const Model& model() const { return m_model; }
  const State& state() const { return m_state; }
  State& state() { return m_state; }
  const ExternalLoads& loads() const { return m_loads; }
  // The load potential V at `state` (J), at the loads' factor (mechanics/frame_loads.hpp).
  double external_potential(const State& state) const;
  const SimulationSettings& settings() const { return m_settings; }
  // Whether the steps run on the settings' step backend, and why not where one was given.
  bool on_step_backend() const;
  const std::string& step_backend_refusal() const;
  double time() const { return m_time; }
  int steps_taken() const { return m_step; }

 private:
  struct Impl;
  struct Attempt;
  // One backward-Euler or variational step of size h from m_state into `trial`, not accepted yet.
  Attempt attempt(double h, State& trial);
  // The static equilibrium at time t_next (motions at t_next, full loads) from m_state into
  // `trial`, with load stepping; velocities zero.
  Attempt static_attempt(double t_next, State& trial);
  // The report's step, time and energies after an accepted step; false (and report.message) when
  // the state or an energy is not finite.
  bool finish(StepReport& report, int step, double time, std::chrono::steady_clock::time_point t0);
  // Records the linear solver's reused factorisation in m_reused (after a completed solve).
  void keep_tangent();
  Model m_model;
  ExternalLoads m_loads;
  SimulationSettings m_settings;
  std::vector<PrescribedMotion> m_motions;
  State m_state;
  double m_time = 0;
  int m_step = 0;
  std::unique_ptr<Impl> m_impl;
  std::unique_ptr<StepController> m_controller;
  double m_extent = 1;  // m, the error estimate's length (model_extent())
  ReusedTangent m_reused;
  AdvanceProgress m_progress;
  PathHistory m_history;
  // After an accepted step of size h from `start` (m_state is its end), before m_step counts it.
  void record_history(State start, double h);
};

// Newton failure or divergence: what() is a one-line message for the user.
class SolverError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Kinetic energy 1/2 v^T M v with the lumped masses and inertias (J).
double kinetic_energy(const Model& model, const State& state);

}  // namespace fascia
