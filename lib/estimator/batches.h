/* Deterministic parallel loop over work items: threads take items one at a
 * time from a shared counter and run each into a tally slot (item i uses
 * slot i % slots); finished items are reduced one by one in item order, so
 * the reduction never depends on the thread count or on timing. There is
 * no barrier per round: a thread waits only when it is `slots` items ahead
 * of the oldest unreduced item, and then sleeps after a short spin, so a
 * thread descheduled by another process (an oversubscribed machine) holds
 * up the others for at most that window (issue 12). */
#ifndef HV_BATCHES_H
#define HV_BATCHES_H

#include <stdint.h>

#include "hetinv/context.h"

/* Slots per thread a pass holds when it runs several threads and its tally
 * is small (pass.c): with one slot per thread, a thread that finishes its
 * item before an older one is reduced must wait; a second slot lets it run
 * on, so the threads drift apart by up to a batch instead of meeting at
 * every one. A large tally (the gradient pass's 33 bytes per voxel) keeps
 * one slot per thread: first touching its pages in every pass cost more
 * than the waits it saves (docs/results/kernel.md). */
#define HV_BATCH_SLOTS_PER_THREAD 2
#define HV_BATCH_SPARE_SLOT_BYTES ((size_t)1 << 20)
#define HV_BATCH_MAX_SLOTS (HV_BATCH_SLOTS_PER_THREAD * HETINV_MAX_THREADS)

typedef struct hv_batch_loop {
  int64_t items;
  int threads; /* at most this many threads */
  void *self;
  /* In parallel: item into tally slot `slot`, which nobody else uses until
   * the item is reduced. */
  void (*run)(void *self, int64_t item, int slot);
  /* Serially, in item order 0, 1, 2, ...: the item's tally in `slot`. */
  void (*reduce)(void *self, int64_t item, int slot);
  /* Tally slots the caller holds (0: as many as threads; at most
   * HV_BATCH_MAX_SLOTS); the loop runs min(threads, slots) threads. */
  int slots;
} hv_batch_loop_t;

void hv_batches_run(const hv_batch_loop_t *loop);

/* The photons of batch b of `batches`: [begin(b), begin(b + 1)). */
static inline uint64_t hv_batch_begin(uint64_t photons, int32_t batches, int32_t b) {
  return (uint64_t)((double)photons * b / batches); /* exact for photons < 2^53 */
}

/* Standard error of a mean from B batch means (their sum and sum of squares). */
double hv_batch_std_error(double sum, double sq, int32_t batches);

#endif
