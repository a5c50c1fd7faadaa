#include "transport/path_log.h"

#include <string.h>

#include "core/alloc.h"

/* Room for one more entry; false (and the log marked) if memory ran out. */
static bool reserve(hv_path_log_t *log) {
  if (log->count == log->capacity) {
    size_t cap = log->capacity ? 2 * log->capacity : 256;
    hv_log_entry_t *e = hv_calloc(log->ctx, cap, sizeof *e);
    if (e == NULL) { /* reported by the render after the photon loop */
      log->out_of_memory = true;
      return false;
    }
    if (log->count) memcpy(e, log->entries, log->count * sizeof *e);
    hv_free(log->ctx, log->entries);
    log->entries = e;
    log->capacity = cap;
  }
  return true;
}

void hv_path_log_add(hv_path_log_t *log, hv_log_kind_t kind, int64_t voxel, double value) {
  if (!reserve(log)) return;
  hv_log_entry_t *e = &log->entries[log->count++];
  e->kind = kind;
  e->cum = log->cum;
  e->u.at.voxel = voxel;
  e->u.at.value = value;
}

void hv_path_log_add_at(hv_path_log_t *log, hv_log_kind_t kind, const double p[3], double value) {
  if (!reserve(log)) return;
  hv_log_entry_t *e = &log->entries[log->count++];
  e->kind = kind;
  e->cum = log->cum;
  e->u.at.voxel = -1;
  e->u.at.value = value;
  memcpy(e->u.at.p, p, sizeof e->u.at.p);
}

void hv_path_log_add_ray(hv_path_log_t *log, const double p[3], const double d[3], double length) {
  if (!reserve(log)) return;
  hv_log_entry_t *e = &log->entries[log->count++];
  e->kind = HV_LOG_RAY;
  e->cum = log->cum;
  memcpy(e->u.ray.p, p, sizeof e->u.ray.p);
  memcpy(e->u.ray.d, d, sizeof e->u.ray.d);
  e->u.ray.length = length;
  e->u.ray.scatter = 0.0;
}

void hv_path_log_release(hv_path_log_t *log) {
  hv_free(log->ctx, log->entries);
  log->entries = NULL;
  log->count = log->capacity = 0;
}
