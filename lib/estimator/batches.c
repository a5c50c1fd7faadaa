#include "estimator/batches.h"

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/error.h"

/* Shared state of one hv_batches_run. Item i runs in slot i % slots; it may
 * start once item i - slots, the slot's previous user, is reduced. Whoever
 * finishes an item reduces every finished item in order from `reduced` on
 * (one reducer at a time, by try-lock), so no thread ever waits for a whole
 * round, only, if it runs `slots` items ahead, for the oldest one. */
typedef struct loop_state {
  const hv_batch_loop_t *loop;
  int64_t slots;
  atomic_int_fast64_t next;    /* next item to hand out */
  atomic_int_fast64_t reduced; /* items [0, reduced) are reduced */
  atomic_int_fast64_t *done;   /* done[s]: the last item finished in slot s, or -1 */
  atomic_bool reducing;        /* the reducer's try-lock */
  atomic_int sleepers;         /* threads in (or entering) the condition wait */
  pthread_mutex_t mutex;
  pthread_cond_t cond; /* signalled when `reduced` grows while someone sleeps */
} loop_state_t;

/* Checks before a waiting thread sleeps: long enough to ride out a slot
 * freed a few microseconds later on a quiet machine, short enough that on
 * a loaded one (another process on the cores) it does not burn the time
 * slice the thread it waits for needs. */
#define HV_SPIN_CHECKS 2000

static void wait_reduced(loop_state_t *st, int64_t at_least) {
  for (int i = 0; i < HV_SPIN_CHECKS; ++i) {
    if (atomic_load(&st->reduced) >= at_least) return;
  }
  atomic_fetch_add(&st->sleepers, 1);
  pthread_mutex_lock(&st->mutex);
  while (atomic_load(&st->reduced) < at_least) pthread_cond_wait(&st->cond, &st->mutex);
  pthread_mutex_unlock(&st->mutex);
  atomic_fetch_sub(&st->sleepers, 1);
}

/* Reduces the finished items that follow the reduced ones, in item order.
 * A thread that finds the lock taken leaves: the holder re-checks after
 * releasing it (all sequentially consistent), so no finished item is left
 * behind. */
static void reduce_ready(loop_state_t *st) {
  const hv_batch_loop_t *loop = st->loop;
  for (;;) {
    if (atomic_exchange(&st->reducing, true)) return;
    int64_t r = atomic_load(&st->reduced);
    bool grew = false;
    while (r < loop->items && atomic_load(&st->done[r % st->slots]) == r) {
      loop->reduce(loop->self, r, (int)(r % st->slots));
      atomic_store(&st->reduced, ++r);
      grew = true;
    }
    atomic_store(&st->reducing, false);
    if (grew && atomic_load(&st->sleepers) > 0) {
      pthread_mutex_lock(&st->mutex);
      pthread_cond_broadcast(&st->cond);
      pthread_mutex_unlock(&st->mutex);
    }
    if (r >= loop->items || atomic_load(&st->done[r % st->slots]) != r) return;
  }
}

void hv_batches_run(const hv_batch_loop_t *loop) {
  enum { MAX_SLOTS = HV_BATCH_MAX_SLOTS };
  atomic_int_fast64_t done[MAX_SLOTS]; /* 16 KiB at most: no allocation to fail */
  loop_state_t st = {.loop = loop, .slots = loop->slots > 0 ? loop->slots : loop->threads};
  if (st.slots < 1) st.slots = 1;
  if (st.slots > MAX_SLOTS) st.slots = MAX_SLOTS;
  st.done = done;
  for (int64_t s = 0; s < st.slots; ++s) atomic_init(&st.done[s], -1);
  atomic_init(&st.next, 0);
  atomic_init(&st.reduced, 0);
  atomic_init(&st.reducing, false);
  atomic_init(&st.sleepers, 0);
  pthread_mutex_init(&st.mutex, NULL);
  pthread_cond_init(&st.cond, NULL);
  int threads = loop->threads < st.slots ? loop->threads : (int)st.slots;
  if (threads < 1) threads = 1;
  const char *entry = hv_api_entry; /* workers' failures name the caller's public function */
#pragma omp parallel num_threads(threads)
  {
    HV_API_ADOPT(entry);
    for (;;) {
      int64_t i = atomic_fetch_add(&st.next, 1);
      if (i >= loop->items) break;
      wait_reduced(&st, i - st.slots + 1); /* the slot's previous item is reduced */
      loop->run(loop->self, i, (int)(i % st.slots));
      atomic_store(&st.done[i % st.slots], i);
      reduce_ready(&st);
    }
  }
  pthread_cond_destroy(&st.cond);
  pthread_mutex_destroy(&st.mutex);
}

double hv_batch_std_error(double sum, double sq, int32_t batches) {
  if (batches < 2) return 0.0;
  double mean = sum / batches, var = (sq / batches - mean * mean) * batches / (batches - 1);
  return var > 0.0 ? sqrt(var / batches) : 0.0;
}
