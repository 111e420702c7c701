#include "process_threads.hpp"

#include <omp.h>

namespace fascia::app {

int process_threads() {
  // Read once, before any bound is set: "all threads" restores it after a run that set fewer.
  static const int at_start = omp_get_max_threads();
  return at_start;
}

void bound_process_threads(int threads) {
  const int all = process_threads();  // read before the first bound
  omp_set_num_threads(threads > 0 ? threads : all);
}

}  // namespace fascia::app
