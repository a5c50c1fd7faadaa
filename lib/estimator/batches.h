/* Deterministic parallel loop over work items: items run in rounds of one
 * per thread, and after each round they are reduced one by one in item
 * order, so the reduction never depends on the thread count. */
#ifndef HV_BATCHES_H
#define HV_BATCHES_H

#include <stdint.h>

typedef struct hv_batch_loop {
  int64_t items;
  int threads;
  void *self;
  void (*run)(void *self, int64_t item, int thread);    /* in parallel */
  void (*reduce)(void *self, int64_t item, int thread); /* serially, in item order */
} hv_batch_loop_t;

void hv_batches_run(const hv_batch_loop_t *loop);

/* The photons of batch b of `batches`: [begin(b), begin(b + 1)). */
static inline uint64_t hv_batch_begin(uint64_t photons, int32_t batches, int32_t b) {
  return (uint64_t)((double)photons * b / batches); /* exact for photons < 2^53 */
}

/* Standard error of a mean from B batch means (their sum and sum of squares). */
double hv_batch_std_error(double sum, double sq, int32_t batches);

#endif
