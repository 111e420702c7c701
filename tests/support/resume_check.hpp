// Continuation from what a checkpoint keeps (io/checkpoint.hpp): a simulation restored at step
// `split` of another one (state, step, time, PCG's reused factorisation, an adaptive run's step
// controller, the predictor's path history) continues to step `total` exactly as the uninterrupted one does. The same check runs
// on the CPU engine (tests/integrate/test_simulation.cpp) and on the CUDA step backend
// (tests/kernels/test_cuda_simulation.cpp), with the backend the settings' factories give.
#pragma once

#include "integrate/simulation.hpp"
#include "model/model.hpp"

#include <algorithm>
#include <memory>
#include <vector>

namespace fascia::test {

// A box model's free end (its largest x) pulled down at 0.5 m/s, its x = 0 face fixed by the
// caller.
inline PrescribedMotion pull_free_end(const Model& model) {
  PrescribedMotion pull;
  double x_max = 0;
  for (int i = 0; i < model.frame_count(); ++i) x_max = std::max(x_max, model.frame_rest_positions[3 * i]);
  for (int i = 0; i < model.frame_count(); ++i)
    if (model.frame_rest_positions[3 * i] > x_max - 1e-9) pull.frames.push_back(i);
  pull.velocity = Vec3{0, 0, -0.5};
  return pull;
}

struct ResumeComparison {
  bool held = false;                     // a factorisation was held at the split
  std::vector<int> cg_full, cg_resumed;  // PCG iterations of steps split+1..total (rows, adaptive)
  std::vector<int> cg_fresh;             // the same, restored without the factorisation
  bool history = false;                  // a path history was held at the split (static, backward Euler)
  State full, resumed, fresh;            // the final states
  State forgetful;                       // restored with the factorisation, without the path history
};

// Runs `total` steps (adaptive: advances to k dt, k = 1..total) uninterrupted, and from step
// `split` again in new simulations restored with and without the reused factorisation, and
// (static steps, backward Euler) with the factorisation but without the path history.
inline ResumeComparison compare_resume(const Model& model, const ExternalLoads& loads,
                                       const std::vector<PrescribedMotion>& motions, const SimulationSettings& settings,
                                       int split, int total) {
  const bool adaptive = settings.adaptive.enabled;
  auto advance = [&](Simulation& s, int k) { return adaptive ? s.advance_to(k * settings.dt) : s.step(); };
  ResumeComparison c;
  Simulation full(model, loads, settings, motions);
  State at_split;
  int step_at_split = 0;
  double time_at_split = 0;
  ReusedTangent tangent;
  StepControllerState controller;
  PathHistory history;
  for (int k = 1; k <= total; ++k) {
    const StepReport r = advance(full, k);
    if (k > split) c.cg_full.push_back(r.cg_iterations);
    if (k == split) {
      at_split = full.state();
      step_at_split = full.steps_taken();
      time_at_split = full.time();
      tangent = full.reused_tangent();
      history = full.path_history();
      if (adaptive) controller = full.controller()->state();
    }
  }
  c.full = full.state();
  c.held = tangent.held;
  c.history = history.held();
  enum class Restored { everything, no_tangent, no_history };
  for (const Restored what : {Restored::everything, Restored::no_tangent, Restored::no_history}) {
    if (what == Restored::no_history && !c.history) break;
    Simulation s(model, loads, settings, motions);
    s.restore(at_split, step_at_split, time_at_split);
    if (what != Restored::no_history) s.restore_path_history(history);
    if (adaptive) s.controller()->restore(controller);
    if (what != Restored::no_tangent && !s.restore_tangent(tangent)) return c;  // resumed stays empty: the check fails
    std::vector<int> ignored;
    std::vector<int>& cg = what == Restored::everything ? c.cg_resumed : what == Restored::no_tangent ? c.cg_fresh : ignored;
    for (int k = split + 1; k <= total; ++k) cg.push_back(advance(s, k).cg_iterations);
    (what == Restored::everything ? c.resumed : what == Restored::no_tangent ? c.fresh : c.forgetful) = s.state();
  }
  return c;
}

}  // namespace fascia::test
