#include "process_threads.hpp"

#include <omp.h>

namespace fascia::app {

void bound_process_threads(int threads) {
  // The team size the process started with (OMP_NUM_THREADS or the cores), read once, before
  // any bound is set: "all threads" restores it after a run that set fewer.
  static const int at_start = omp_get_max_threads();
  omp_set_num_threads(threads > 0 ? threads : at_start);
}

}  // namespace fascia::app
