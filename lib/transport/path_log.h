/* The score log of one path, for score-function gradients (Eqs. 17–22).
 *
 * A path's contribution f factors into per-segment transmittances
 * exp(-σt·ℓ), per-vertex σs and phase values. Each factor's log-derivative
 * (the entry's "local score") applies to every splat made after it on the
 * path. Entries record the running sum of splat weights (r·c) at the time
 * they were logged, so that at the end of the path each entry's share is
 * total - cum: one pass, no quadratic cost. */
#ifndef HV_PATH_LOG_H
#define HV_PATH_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "medium/phase.h"
#include "transport/grid.h"

/* The vertex scores (1/σs; ∂ log f_p / ∂g) are worked out when the log is
 * applied (hv_log_vertex_score), not when the entry is made: most paths
 * never reach a sensor, and a scattering's three divisions and its σs load
 * are then wasted. */
typedef enum hv_log_kind {
  HV_LOG_SEGMENT, /* value = ℓ in voxel: ∂/∂σa = ∂/∂σs = -ℓ */
  HV_LOG_RAY,     /* a flight not yet split into voxels (uniform grids; delta-tracked flights) */
  HV_LOG_SCATTER, /* a scattering vertex: ∂/∂σs = 1/σs of its voxel; value unused */
  HV_LOG_PHASE,   /* value = cosθ of the vertex's scattering: ∂/∂g = ∂ log f_p(cosθ) / ∂g */
} hv_log_kind_t;

typedef struct hv_log_entry {
  hv_log_kind_t kind;
  double cum;
  union {
    struct {
      int64_t voxel; /* < 0: not yet known; the voxel holding p */
      double value;
      double p[3];
    } at;          /* SEGMENT, SCATTER, PHASE */
    struct {
      double p[3], d[3], length;
      int scatter; /* 1: a scattering vertex ends it (its σs score), or 0 */
      /* 1: that vertex's phase score too, at cos_theta (a PHASE entry
       * folded in where no splat can come between: hv_path_log_set_ray_vertex) */
      int phase;
      double cos_theta;
    } ray;         /* RAY */
  } u;
} hv_log_entry_t;

typedef struct hv_path_log {
  hv_log_entry_t *entries;
  size_t count, capacity;
  double cum; /* splat weight so far */
  bool scored; /* a splat was made: without one, every entry's share is 0 */
  const hetinv_context_t *ctx;
  bool out_of_memory;
} hv_path_log_t;

/* Doubles the log's room (out of line: rare); false, and the log marked,
 * if memory ran out. */
bool hv_path_log_grow(hv_path_log_t *log);

/* Room for one more entry; false if memory ran out. */
static inline bool hv_path_log_reserve(hv_path_log_t *log) {
  return log->count < log->capacity || hv_path_log_grow(log);
}

/* Inline: the gradient pass logs one entry per voxel crossing. */
static inline void hv_path_log_add(hv_path_log_t *log, hv_log_kind_t kind, int64_t voxel,
                                   double value) {
  if (!hv_path_log_reserve(log)) return;
  hv_log_entry_t *e = &log->entries[log->count++];
  e->kind = kind;
  e->cum = log->cum;
  e->u.at.voxel = voxel;
  e->u.at.value = value;
}
/* A straight segment not yet split into voxels. */
static inline void hv_path_log_add_ray(hv_path_log_t *log, const double p[3], const double d[3],
                                       double length) {
  if (!hv_path_log_reserve(log)) return;
  hv_log_entry_t *e = &log->entries[log->count++];
  e->kind = HV_LOG_RAY;
  e->cum = log->cum;
  for (int i = 0; i < 3; ++i) {
    e->u.ray.p[i] = p[i];
    e->u.ray.d[i] = d[i];
  }
  e->u.ray.length = length;
  e->u.ray.scatter = 0;
  e->u.ray.phase = 0;
}

/* A vertex entry whose voxel is found from its position only if needed. */
static inline void hv_path_log_add_at(hv_path_log_t *log, hv_log_kind_t kind, const double p[3],
                                      double value) {
  if (!hv_path_log_reserve(log)) return;
  hv_log_entry_t *e = &log->entries[log->count++];
  e->kind = kind;
  e->cum = log->cum;
  e->u.at.voxel = -1;
  e->u.at.value = value;
  for (int i = 0; i < 3; ++i) e->u.at.p[i] = p[i];
}

/* Marks the last RAY entry as ended by a scattering vertex, whose σs score
 * it then carries (same running total: no splat happens in between). */
static inline void hv_path_log_set_ray_scatter(hv_path_log_t *log) {
  if (log->count > 0 && log->entries[log->count - 1].kind == HV_LOG_RAY) {
    log->entries[log->count - 1].u.ray.scatter = 1;
  }
}

/* Marks the last RAY entry as ended by a scattering vertex that scattered
 * at cosθ: it then carries the vertex's σs score and its phase score, as
 * set_ray_scatter followed by a PHASE entry at the ray's end would, with
 * one entry instead of two. Only where nothing can splat between the
 * vertex and its scattering (no vertex sensor): both scores then have the
 * ray's running total. The last entry is the ray (the caller logged it). */
static inline void hv_path_log_set_ray_vertex(hv_path_log_t *log, double cos_theta) {
  if (log->count > 0 && log->entries[log->count - 1].kind == HV_LOG_RAY) {
    hv_log_entry_t *e = &log->entries[log->count - 1];
    e->u.ray.scatter = 1;
    e->u.ray.phase = 1;
    e->u.ray.cos_theta = cos_theta;
  }
}

/* ∂ log f_p(cosθ) / ∂g of a scattering at voxel k (the tracer's phase
 * there). */
static inline double hv_log_phase_score(const hv_grid_t *grid, int64_t k, double cos_theta) {
  const hv_phase_t phase = {HV_PHASE_HG, grid->voxel[k].g};
  return hv_phase_dlog_dg(phase, cos_theta);
}

/* The score of a SCATTER or PHASE entry at voxel k (the vertex's). */
static inline double hv_log_vertex_score(const hv_grid_t *grid, const hv_log_entry_t *e, int64_t k) {
  if (e->kind == HV_LOG_SCATTER) return 1.0 / grid->sigma_s[k];
  return hv_log_phase_score(grid, k, e->u.at.value);
}
void hv_path_log_release(hv_path_log_t *log);

static inline void hv_path_log_reset(hv_path_log_t *log) {
  log->count = 0;
  log->cum = 0.0;
  log->scored = false;
}


#endif
