/* What the photons of one emitter must score: its sensors, grouped, and the
 * rows (value ranges and pathlength windows) each sensor feeds. Built from a
 * measurement set before a render. */
#ifndef HV_PLAN_H
#define HV_PLAN_H

#include <stdint.h>

#include "hetinv/measurement.h"
#include "sampling/emitter_internal.h"
#include "sampling/pathlength_internal.h"
#include "sampling/sensor_internal.h"

typedef struct hv_row_target {
  size_t offset;   /* first value of the row */
  size_t local;    /* its first value among the plan's own (hv_plan_t::value_count) */
  int32_t pixels;  /* stride between bins */
  const hetinv_pathlength_t *pathlength;
} hv_row_target_t;

struct hv_sensor_kind;

typedef struct hv_sensor_target {
  const hetinv_sensor_t *sensor;
  const struct hv_sensor_kind *kind; /* the sensor's (transport/sensor_kind.h) */
  int32_t first_row, row_count; /* into hv_plan_t::rows */
  double cache[4]; /* the kind's per-target data (its prepare hook) */
  double reach_lo[3], reach_hi[3]; /* the vertices it can score from (its kind's reach hook) */
} hv_sensor_target_t;

typedef struct hv_plan {
  const hetinv_emitter_t *emitter;
  uint32_t key;                        /* the emitter's random-stream key */
  /* Its sensors in order of first use, and those whose kind scores at a
   * scattering vertex / at a boundary exit, in the same order. */
  int32_t target_count, vertex_count, exit_count;
  hv_sensor_target_t *targets;
  const hv_sensor_target_t **at_vertex, **at_exit;
  /* The box around the vertex sensors' reach boxes (empty without one): a
   * vertex outside it calls no at_vertex hook. */
  double reach_lo[3], reach_hi[3];
  hv_row_target_t *rows;
  int32_t range_count;                 /* the value ranges its rows cover */
  size_t *range_lo, *range_hi;
  /* Values of its rows together, numbered by hv_row_target_t::local: a
   * tally that only this plan's photons fill can be this small (the
   * tangent pass keeps K doubles per value). */
  size_t value_count;
} hv_plan_t;

typedef struct hv_plans {
  int32_t count;
  hv_plan_t *plan;
  const hetinv_context_t *ctx;
} hv_plans_t;

/* One plan per distinct emitter of the set, in order of first use. */
hetinv_result_t hv_plans_build(const hetinv_measurements_t *set, hv_plans_t *out);
void hv_plans_release(hv_plans_t *plans);

#endif
