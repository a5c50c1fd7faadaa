#include "transport/plan.h"

#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "sampling/measurements_internal.h"
#include "transport/sensor_kind.h"

void hv_plans_release(hv_plans_t *plans) {
  for (int32_t i = 0; i < plans->count && plans->plan; ++i) {
    hv_plan_t *p = &plans->plan[i];
    hv_free(plans->ctx, p->targets);
    hv_free(plans->ctx, p->at_vertex);
    hv_free(plans->ctx, p->at_exit);
    hv_free(plans->ctx, p->rows);
    hv_free(plans->ctx, p->range_lo);
    hv_free(plans->ctx, p->range_hi);
  }
  hv_free(plans->ctx, plans->plan);
  plans->plan = NULL;
  plans->count = 0;
}

/* Fills one emitter's plan from the rows that use it (row_ids, n of them). */
static bool fill_plan(const hetinv_measurements_t *set, const hetinv_context_t *ctx,
                      const int32_t *row_ids, int32_t n, hv_plan_t *p) {
  p->rows = hv_calloc(ctx, (size_t)n, sizeof *p->rows);
  p->targets = hv_calloc(ctx, (size_t)n, sizeof *p->targets);
  p->at_vertex = hv_calloc(ctx, (size_t)n, sizeof *p->at_vertex);
  p->at_exit = hv_calloc(ctx, (size_t)n, sizeof *p->at_exit);
  p->range_lo = hv_calloc(ctx, (size_t)n, sizeof(size_t));
  p->range_hi = hv_calloc(ctx, (size_t)n, sizeof(size_t));
  if (!p->rows || !p->targets || !p->at_vertex || !p->at_exit || !p->range_lo || !p->range_hi) return false;
  for (int a = 0; a < 3; ++a) {
    p->reach_lo[a] = (double)INFINITY;
    p->reach_hi[a] = -(double)INFINITY;
  }
  /* Group rows by sensor, keeping the order of first use. */
  int32_t placed = 0;
  for (int32_t i = 0; i < n; ++i) {
    const hetinv_sensor_t *s = set->rows[row_ids[i]].sensor;
    bool seen = false;
    for (int32_t j = 0; j < i && !seen; ++j) seen = set->rows[row_ids[j]].sensor == s;
    if (seen) continue;
    hv_sensor_target_t *t = &p->targets[p->target_count++];
    t->sensor = s;
    t->kind = s->kind;
    t->first_row = placed;
    for (int32_t j = i; j < n; ++j) {
      const hv_row_t *r = &set->rows[row_ids[j]];
      if (r->sensor != s) continue;
      p->rows[placed++] = (hv_row_target_t){r->offset, p->value_count, r->pixels, r->pathlength};
      p->value_count += (size_t)r->pixels * (size_t)r->bins;
      t->row_count++;
    }
    if (t->kind->prepare) t->kind->prepare(t);
    if (t->kind->at_vertex) {
      p->at_vertex[p->vertex_count++] = t;
      for (int a = 0; a < 3; ++a) {
        t->reach_lo[a] = -(double)INFINITY;
        t->reach_hi[a] = (double)INFINITY;
      }
      if (t->kind->reach) t->kind->reach(s, t->reach_lo, t->reach_hi);
      for (int a = 0; a < 3; ++a) {
        p->reach_lo[a] = fmin(p->reach_lo[a], t->reach_lo[a]);
        p->reach_hi[a] = fmax(p->reach_hi[a], t->reach_hi[a]);
      }
    }
    if (t->kind->at_exit) p->at_exit[p->exit_count++] = t;
  }
  for (int32_t i = 0; i < n; ++i) {
    const hv_row_t *r = &set->rows[row_ids[i]];
    p->range_lo[i] = r->offset;
    p->range_hi[i] = r->offset + (size_t)r->pixels * (size_t)r->bins;
  }
  p->range_count = n;
  return true;
}

hetinv_result_t hv_plans_build(const hetinv_measurements_t *set, hv_plans_t *out) {
  const hetinv_context_t *ctx = set->ctx;
  *out = (hv_plans_t){.ctx = ctx};
  int32_t rows = set->row_count;
  int32_t *emitter_of = hv_calloc(ctx, (size_t)rows, sizeof(int32_t));
  int32_t *ids = hv_calloc(ctx, (size_t)rows, sizeof(int32_t));
  out->plan = hv_calloc(ctx, (size_t)rows, sizeof(hv_plan_t));
  bool ok = emitter_of && ids && out->plan;
  /* Distinct emitters in order of first use; the order fixes their random keys. */
  for (int32_t r = 0; ok && r < rows; ++r) {
    int32_t e = 0;
    while (e < out->count && out->plan[e].emitter != set->rows[r].emitter) ++e;
    if (e == out->count) {
      out->plan[e].emitter = set->rows[r].emitter;
      out->plan[e].key = (uint32_t)e;
      out->count++;
    }
    emitter_of[r] = e;
  }
  for (int32_t e = 0; ok && e < out->count; ++e) {
    int32_t n = 0;
    for (int32_t r = 0; r < rows; ++r) {
      if (emitter_of[r] == e) ids[n++] = r;
    }
    ok = fill_plan(set, ctx, ids, n, &out->plan[e]);
  }
  hv_free(ctx, emitter_of);
  hv_free(ctx, ids);
  if (!ok) {
    hv_plans_release(out);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the render plan");
  }
  return HETINV_SUCCESS;
}
