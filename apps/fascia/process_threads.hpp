#pragma once

namespace fascia {
struct Model;
}

namespace fascia::app {

// The OpenMP team size the process started with: OMP_NUM_THREADS, or the cores it may run on
// (its CPU affinity, which a Slurm job step sets to its allocation).
int process_threads();

// The CPU threads of a run's step for `requested` (solver.threads, --threads): that many when
// > 0; for 0, one per kElementsPerThread elements (samples and shell triangles), at least one and
// at most `available`. A small scene's step is a few hundred short parallel regions, and a large
// team costs more to wake for each than it saves: on a 16-core host the scenes of scenes/ at their
// own resolution (430 to 1,373 samples) ran no faster with 16 threads than with 1 to 4, and this
// rule (1 to 3 threads there) took 0.75 to 1.05 times as long per step as 16 threads. The cores a
// step leaves free write its rows (cmd_run.cpp). The pelvis at 16 k and 56 k samples gets every
// core of a 16-core host.
//
constexpr int kElementsPerThread = 500;
// Where that is every core of several, the run writes a row after each step (row_per_step: a
// dynamic integrator with fixed steps, output.every 1) and the step has fewer than kElementsPerCoreOwned elements
// per core, the step takes one core fewer and leaves it to its rows, which are then formed and
// written while the next step runs instead of between steps: a small step gains little from its
// last core, and a row costs a fair part of a step of a few Newton iterations. On a 2-core
// machine (30 steps, five interleaved runs, median ms per step, 2 threads against 1 and the rows
// on the other core): block_mesh 9.2 against 7.1, coupling 36.9 against 33.1, liver 45.3 against
// 38.0, meshless_slab 39.5 against 37.1, the pelvis 34.0 against 28.4, tool_pull 30.4 against
// 28.4; the pelvis at 16,945 elements (8,473 per core) was faster on both cores (10 steps in
// 11.7-12.1 s against 13.8-15.1), and so were the static beams (one row after 19-21 Newton
// iterations with direct solves: beam 260-362 ms against 340-370, beam_hex 374-566 against
// 542-620).
constexpr int kElementsPerCoreOwned = 2 * kElementsPerThread;
int step_threads(const Model& model, int requested, int available, bool row_per_step);

// Bounds every OpenMP team of the process to `threads` (0 = as many as at program start), the
// sparse factorisation's BLAS and Eigen's products included: they size their teams from
// omp_get_max_threads(), and with more threads than the engine's own loops use, their idle
// workers spin and take the cores from the work.
void bound_process_threads(int threads);

}  // namespace fascia::app
