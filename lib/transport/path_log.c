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

void hv_path_log_apply(const hv_path_log_t *log, double *grad, size_t voxels) {
  double *ga = grad, *gs = grad + voxels, *gg = grad + 2 * voxels;
  for (size_t i = 0; i < log->count; ++i) {
    const hv_log_entry_t *e = &log->entries[i];
    double w = log->cum - e->cum;
    if (w == 0.0) continue;
    switch (e->kind) {
      case HV_LOG_SEGMENT:
        ga[e->voxel] -= e->value * w;
        gs[e->voxel] -= e->value * w;
        break;
      case HV_LOG_SCATTER: gs[e->voxel] += e->value * w; break;
      case HV_LOG_PHASE: gg[e->voxel] += e->value * w; break;
    }
  }
}
