#include "transport/path_jvp.h"

#include <string.h>

#include "sampling/pathlength_internal.h"
#include "transport/walk.h"

void hv_jvp_path_begin(hv_jvp_state_t *st) {
  memset(st->run, 0, (size_t)st->tangents * sizeof(double));
  st->path_done = 0;
  st->path_end.k = -1;
}

/* The tangents' entries of parameter block p at voxel k. */
static const double *entries(const hv_jvp_state_t *st, int p, int64_t k) {
  return st->tangent + ((size_t)p * st->voxels + (size_t)k) * (size_t)st->tangents;
}

/* run += x · (entries of parameter block p at voxel k). */
static void add_scaled(const hv_jvp_state_t *st, int p, int64_t k, double x, double *run) {
  if (st->sparse_start) {
    size_t row = (size_t)p * st->voxels + (size_t)k;
    for (size_t i = st->sparse_start[row]; i < st->sparse_start[row + 1]; ++i) {
      run[st->sparse_index[i]] += x * st->sparse_value[i];
    }
    return;
  }
  const double *e = entries(st, p, k);
  for (int32_t t = 0; t < st->tangents; ++t) run[t] += x * e[t];
}

void hv_jvp_chain_begin(hv_jvp_state_t *st, int64_t vertex, double dlog_dg) {
  double *run = st->run + st->tangents;
  memset(run, 0, (size_t)st->tangents * sizeof(double));
  add_scaled(st, HETINV_PARAM_G, vertex, dlog_dg, run);
  st->chain_done = 0;
  st->chain_end.k = -1;
}

/* run -= length·(v_σa + v_σs) of voxel k: a segment's transmittance score. */
static void add_extinction(const hv_jvp_state_t *st, int64_t k, double length, double *run) {
  if (st->sparse_start) {
    add_scaled(st, HETINV_PARAM_SIGMA_A, k, -length, run);
    add_scaled(st, HETINV_PARAM_SIGMA_S, k, -length, run);
    return;
  }
  const double *a = entries(st, HETINV_PARAM_SIGMA_A, k), *s = entries(st, HETINV_PARAM_SIGMA_S, k);
  for (int32_t t = 0; t < st->tangents; ++t) run[t] -= length * (a[t] + s[t]);
}

typedef struct extinction_visit {
  const hv_jvp_state_t *st;
  double *run;
} extinction_visit_t;

static inline void add_extinction_visit(void *user, int64_t k, double seg) {
  const extinction_visit_t *x = user;
  add_extinction(x->st, k, seg, x->run);
}

/* Adds the entries of `log` not yet summed to run. */
static void catch_up(const hv_jvp_state_t *st, const hv_path_log_t *log, size_t *done,
                     hv_ray_t *end, double *run) {
  for (size_t i = *done; i < log->count; ++i) {
    const hv_log_entry_t *e = &log->entries[i];
    if (e->kind == HV_LOG_RAY) {
      /* Split as hv_grad_apply_log splits it. */
      extinction_visit_t x = {st, run};
      hv_walk_log_ray(st->grid, e, end, add_extinction_visit, &x);
      if (e->u.ray.scatter) add_scaled(st, HETINV_PARAM_SIGMA_S, end->k, 1.0 / st->grid->sigma_s[end->k], run);
      if (e->u.ray.phase) add_scaled(st, HETINV_PARAM_G, end->k, hv_log_phase_score(st->grid, end->k, e->u.ray.cos_theta), run);
      continue;
    }
    int64_t k = e->u.at.voxel;
    if (k < 0) k = end->k; /* the vertex that ended the last ray */
    if (k < 0) {
      hv_ray_t r = {.p = {e->u.at.p[0], e->u.at.p[1], e->u.at.p[2]}, .d = {0.0, 0.0, 0.0}};
      hv_ray_locate(st->grid, &r);
      k = r.k;
    }
    switch (e->kind) {
      case HV_LOG_SEGMENT: add_extinction(st, k, e->u.at.value, run); break;
      case HV_LOG_SCATTER: add_scaled(st, HETINV_PARAM_SIGMA_S, k, hv_log_vertex_score(st->grid, e, k), run); break;
      case HV_LOG_PHASE: add_scaled(st, HETINV_PARAM_G, k, hv_log_vertex_score(st->grid, e, k), run); break;
      case HV_LOG_RAY: break;
    }
  }
  *done = log->count;
}

void hv_jvp_splat(hv_jvp_state_t *st, const hv_path_log_t *path, const hv_path_log_t *chain,
                  const hetinv_pathlength_t *pl, double tau, double value, double *dst,
                  size_t stride) {
  int32_t T = st->tangents;
  double *run = st->run, *chain_run = st->run + T;
  catch_up(st, path, &st->path_done, &st->path_end, run);
  if (chain) catch_up(st, chain, &st->chain_done, &st->chain_end, chain_run);
  HV_FOR_EACH_BIN(pl, tau, {
    double *d = dst + (size_t)bin * stride;
    double x = value * weight;
    if (chain) {
      for (int32_t t = 0; t < T; ++t) d[t] += x * (run[t] + chain_run[t]);
    } else {
      for (int32_t t = 0; t < T; ++t) d[t] += x * run[t];
    }
  });
}
