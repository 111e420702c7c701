// Timing of one full implicit step as in the paper's Table 3: a backward-Euler step linearised
// once (one Newton iteration), solved with exactly 60 CG iterations, on tetrahedral beams with
// one sample per tetrahedron (4 neighbours per sample). Timings are for benchmarks only.
#pragma once

#include "mechanics/external_loads.hpp"
#include "model/model.hpp"
#include "solve/linear_solver.hpp"

#include <vector>

namespace fascia {

// The paper's Table 3: samples, CPU ms (Xeon W3520, one thread), GTX 570 ms.
struct PaperTiming {
  int samples;
  double cpu_ms;
  double gpu_ms;
};
const std::vector<PaperTiming>& paper_table3();

// A beam of tetrahedra (1 sample each) with about `samples` samples, clamped at x = 0.
// neighbours_per_sample: 4 (tetrahedra) or 8 (hexahedra, 1 sample each).
Model bench_beam_model(int samples, int neighbours_per_sample = 4);

struct StepTiming {
  int samples = 0, frames = 0, neighbours = 0, threads = 0, cg_iterations = 0;
  double ms_per_step = 0;  // median over repetitions, wall clock
  // Median process CPU time per step (all threads, OpenMP spin-waits included). With one thread
  // and a busy machine it tells the work done from the time spent waiting for a core.
  double cpu_ms_per_step = 0;
  int repetitions = 0;
};

// The benchmark step (the same on every backend): backward Euler, h = 10 ms, no damping, gravity
// (0, 0, -9.81) m/s^2 on the samples, from the rest state; one Newton iteration
// (NewtonSettings::fixed_iterations = 1) whose linear solve runs exactly cg_iterations iterations
// of `method` (cg: the paper's CG; pcg: block-Jacobi PCG).
constexpr double kBenchStepDt = 0.01;
ExternalLoads bench_step_loads();
LinearSettings bench_linear_settings(LinearMethod method, int cg_iterations);

// Times full implicit steps (forces, tangent preparation, fixed-count CG, update) with the CPU
// engine. Repeats until min_seconds have passed (at least 3 steps) after one warm-up step.
StepTiming time_cpu_step(const Model& model, int threads, int cg_iterations = 60, double min_seconds = 0.5,
                         LinearMethod method = LinearMethod::cg);

}  // namespace fascia
