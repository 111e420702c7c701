#pragma once

namespace fascia::app {

// The OpenMP team size the process started with: OMP_NUM_THREADS, or the cores it may run on
// (its CPU affinity, which a Slurm job step sets to its allocation).
int process_threads();

// Bounds every OpenMP team of the process to `threads` (0 = as many as at program start), the
// sparse factorisation's BLAS and Eigen's products included: they size their teams from
// omp_get_max_threads(), and with more threads than the engine's own loops use, their idle
// workers spin and take the cores from the work.
void bound_process_threads(int threads);

}  // namespace fascia::app
