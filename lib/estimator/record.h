/* A growable array of doubles: the partial results of finished emitters,
 * in emitter order, as they are handed from the rank that traced them to
 * every rank (core/comm.h). Integers (counts, indices < 2^53) are stored
 * as doubles, exactly. */
#ifndef HV_RECORD_H
#define HV_RECORD_H

#include <stdbool.h>
#include <stddef.h>
#include <string.h>

#include "core/alloc.h"

typedef struct hv_record {
  const hetinv_context_t *ctx;
  double *data;
  size_t count, capacity;
  bool out_of_memory; /* a push was dropped */
} hv_record_t;

/* Room for n more doubles; false (and out_of_memory set) if it cannot grow. */
static inline bool hv_record_reserve(hv_record_t *r, size_t n) {
  if (r->out_of_memory) return false;
  if (r->count + n <= r->capacity) return true;
  size_t cap = r->capacity ? r->capacity : 256;
  while (cap < r->count + n) {
    if (cap > (size_t)-1 / (2 * sizeof(double))) {
      r->out_of_memory = true;
      return false;
    }
    cap *= 2;
  }
  double *grown = hv_calloc(r->ctx, cap, sizeof(double));
  if (grown == NULL) {
    r->out_of_memory = true;
    return false;
  }
  if (r->count) memcpy(grown, r->data, r->count * sizeof(double));
  hv_free(r->ctx, r->data);
  r->data = grown;
  r->capacity = cap;
  return true;
}

/* Appends x; call hv_record_reserve first for the room. */
static inline void hv_record_put(hv_record_t *r, double x) { r->data[r->count++] = x; }

static inline void hv_record_release(hv_record_t *r) {
  hv_free(r->ctx, r->data);
  r->data = NULL;
  r->count = r->capacity = 0;
}

#endif
