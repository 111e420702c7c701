// A backend that runs a whole step's minimisation where its data lives (the CUDA device:
// kernels/cuda_step.hpp): the same potential as StepPotential (step_potential.hpp) and the same
// Newton settings, with the state uploaded once per solve and read back once. Simulation keeps
// prescribed motions, load stepping and the reports; the backend owns everything inside a solve.
#pragma once

#include "integrate/tangent_origin.hpp"
#include "mechanics/external_loads.hpp"
#include "model/model.hpp"
#include "model/state.hpp"
#include "solve/newton.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace fascia {

struct SimulationSettings;


class StepBackend {
 public:
  virtual ~StepBackend() = default;
  // Backward Euler from `start` (q_n, v_n): minimises the incremental potential with Rayleigh mass
  // damping alpha from `trial` (prescribed frames already moved), which holds the result with its
  // velocities Delta / dt.
  virtual NewtonResult backward_euler(const State& start, State& trial, double dt, double rayleigh_mass,
                                      const NewtonSettings& settings, double reference_force) = 0;
  // The variational step's discrete Euler-Lagrange equations (variational_step.hpp, (4)) over dt
  // from `start` with its reduced momenta p_start [N][6] (N s): `end` enters as the predictor
  // (fixed DOFs at their t_{k+1} values, attached frames synced) and leaves as the solution, its
  // velocities untouched; where it converged, p_end holds the momenta D_2 S of (5) there [N][6].
  // force_scale (N) is the reference force of Newton's relative residual (r / h, N).
  virtual NewtonResult variational(const State& start, State& end, double dt, const std::vector<double>& p_start,
                                   const NewtonSettings& settings, double force_scale, std::vector<double>& p_end) = 0;
  // Static equilibrium with load stepping (solve/newton.hpp, newton_load_stepping) from `state`
  // (updated in place). set_load_factor(f) applies factor f to the host's loads and returns the
  // reference force at that factor (N); the backend applies the same factor to its own.
  virtual NewtonResult equilibrium(State& state, const NewtonSettings& settings, const LoadStepping& stepping,
                                   const std::function<double(double)>& set_load_factor) = 0;
  // Elastic energy of every force field at state (J).
  virtual double elastic_energy(const State& state) = 0;
  // The factorisation the next solve reuses (pcg + cholmod), as a checkpoint keeps it; held =
  // false when there is none (shift_step is the last factorisation's either way).
  virtual ReusedTangent kept_tangent() const = 0;
  // Computes the factorisation of `tangent` (from kept_tangent() of an earlier run of the same
  // scene) as the one the next solves reuse; one not held sets where the next factorisation's
  // shift search starts. False where it cannot be repeated exactly.
  virtual bool restore_tangent(const ReusedTangent& tangent, const SimulationSettings& settings) = 0;
};

// Makes the backend for a model and its loads (which outlive it), or returns null where the
// backend does not cover the model or the settings; `why` then says why (for the log).
using StepBackendFactory = std::function<std::unique_ptr<StepBackend>(
    const Model& model, const ExternalLoads& loads, const SimulationSettings& settings, std::string& why)>;

}  // namespace fascia
