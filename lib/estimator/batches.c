#include "estimator/batches.h"

#include <math.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/error.h"

void hv_batches_run(const hv_batch_loop_t *loop) {
  const char *entry = hv_api_entry; /* workers' failures name the caller's public function */
#pragma omp parallel num_threads(loop->threads)
  {
    HV_API_ADOPT(entry);
    int tid = 0, team = 1;
#ifdef _OPENMP
    tid = omp_get_thread_num();
    team = omp_get_num_threads(); /* the runtime may give fewer than asked */
#endif
    for (int64_t first = 0; first < loop->items; first += team) {
      if (first + tid < loop->items) loop->run(loop->self, first + tid, tid);
#pragma omp barrier
#pragma omp single
      for (int t = 0; t < team && first + t < loop->items; ++t) loop->reduce(loop->self, first + t, t);
      /* the single's implicit barrier keeps each thread's tally until reduced */
    }
  }
}

double hv_batch_std_error(double sum, double sq, int32_t batches) {
  if (batches < 2) return 0.0;
  double mean = sum / batches, var = (sq / batches - mean * mean) * batches / (batches - 1);
  return var > 0.0 ? sqrt(var / batches) : 0.0;
}
