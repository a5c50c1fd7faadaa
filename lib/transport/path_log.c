#include "transport/path_log.h"

#include <string.h>

#include "core/alloc.h"

void hv_path_log_add(hv_path_log_t *log, hv_log_kind_t kind, int64_t voxel, double value) {
  if (log->count == log->capacity) {
    size_t cap = log->capacity ? 2 * log->capacity : 256;
    hv_log_entry_t *e = hv_calloc(log->ctx, cap, sizeof *e);
    if (e == NULL) { /* reported by the render after the photon loop */
      log->out_of_memory = true;
      return;
    }
    if (log->count) memcpy(e, log->entries, log->count * sizeof *e);
    hv_free(log->ctx, log->entries);
    log->entries = e;
    log->capacity = cap;
  }
  log->entries[log->count++] = (hv_log_entry_t){voxel, value, log->cum, kind};
}

void hv_path_log_release(hv_path_log_t *log) {
  hv_free(log->ctx, log->entries);
  log->entries = NULL;
  log->count = log->capacity = 0;
}
