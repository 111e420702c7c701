#include "process_threads.hpp"

#include "model/model.hpp"

#include <algorithm>

#include <omp.h>

namespace fascia::app {

int process_threads() {
  // Read once, before any bound is set: "all threads" restores it after a run that set fewer.
  static const int at_start = omp_get_max_threads();
  return at_start;
}

int step_threads(const Model& model, int requested, int available, bool row_per_step) {
  if (requested > 0) return requested;
  long elements = model.sample_count();
  for (const Shell& shell : model.shells) elements += static_cast<long>(shell.triangles.size() / 3);
  const long wanted = (elements + kElementsPerThread - 1) / kElementsPerThread;
  const int cores = std::max(available, 1);
  const int threads = static_cast<int>(std::clamp<long>(wanted, 1, cores));
  // Every core of several, few elements on each, a row per step: one core is left to the rows.
  if (row_per_step && threads == cores && cores > 1 && elements < static_cast<long>(kElementsPerCoreOwned) * cores)
    return cores - 1;
  return threads;
}

void bound_process_threads(int threads) {
  const int all = process_threads();  // read before the first bound
  omp_set_num_threads(threads > 0 ? threads : all);
}

}  // namespace fascia::app
