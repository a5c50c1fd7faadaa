#include "transport/path_log.h"

#include <string.h>

#include "core/alloc.h"

bool hv_path_log_grow(hv_path_log_t *log) {
  size_t cap = log->capacity ? 2 * log->capacity : 256;
  hv_log_entry_t *e = hv_calloc_apart(log->ctx, cap, sizeof *e); /* one thread's */
  if (e == NULL) { /* reported by the render after the photon loop */
    log->out_of_memory = true;
    return false;
  }
  if (log->count) memcpy(e, log->entries, log->count * sizeof *e);
  hv_free(log->ctx, log->entries);
  log->entries = e;
  log->capacity = cap;
  return true;
}

void hv_path_log_release(hv_path_log_t *log) {
  hv_free(log->ctx, log->entries);
  log->entries = NULL;
  log->count = log->capacity = 0;
}
