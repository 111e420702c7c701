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
constexpr int kElementsPerThread = 500;
int step_threads(const Model& model, int requested, int available);

// Bounds every OpenMP team of the process to `threads` (0 = as many as at program start), the
// sparse factorisation's BLAS and Eigen's products included: they size their teams from
// omp_get_max_threads(), and with more threads than the engine's own loops use, their idle
// workers spin and take the cores from the work.
void bound_process_threads(int threads);

}  // namespace fascia::app
