// Timing of one full implicit step as in the paper's Table 3: a backward-Euler step linearised
// once (one Newton iteration), solved with exactly 60 CG iterations, on tetrahedral beams with
// one sample per tetrahedron (4 neighbours per sample). Timings are for benchmarks only.
#pragma once

#include "model/model.hpp"

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

// Times full implicit steps (forces, tangent preparation, fixed-count CG, update) with the CPU
// engine. Repeats until min_seconds have passed (at least 3 steps) after one warm-up step.
StepTiming time_cpu_step(const Model& model, int threads, int cg_iterations = 60, double min_seconds = 0.5);

}  // namespace fascia
