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
  int32_t pixels;  /* stride between bins */
  const hetinv_pathlength_t *pathlength;
} hv_row_target_t;

typedef struct hv_sensor_target {
  const hetinv_sensor_t *sensor;
  int32_t first_row, row_count; /* into hv_plan_t::rows */
  double reflectance[3]; /* orthographic: Fresnel R of dir_in against each axis' faces */
} hv_sensor_target_t;

typedef struct hv_plan {
  const hetinv_emitter_t *emitter;
  uint32_t key;                        /* the emitter's random-stream key */
  int32_t ortho_count, hemi_count;
  hv_sensor_target_t *ortho, *hemi;
  hv_row_target_t *rows;
  int32_t range_count;                 /* the value ranges its rows cover */
  size_t *range_lo, *range_hi;
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
