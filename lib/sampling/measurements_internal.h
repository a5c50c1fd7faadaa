/* Measurement sets: rows and the arrays of their values. */
#ifndef HV_MEASUREMENTS_INTERNAL_H
#define HV_MEASUREMENTS_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "hetinv/measurement.h"
#include "sampling/geometry.h"

typedef struct hv_row {
  const hetinv_emitter_t *emitter;
  const hetinv_sensor_t *sensor;
  const hetinv_pathlength_t *pathlength;
  size_t offset; /* first value */
  int32_t pixels, bins;
} hv_row_t;

struct hetinv_measurements {
  hetinv_context_t *ctx;
  hv_geometry_t geo; /* of the first row; every row must match */
  int32_t row_count, row_capacity;
  hv_row_t *rows;
  size_t value_count, value_capacity;
  double *values, *std_errors, *weights;
  double *clip_below, *clip_above; /* HETINV_ESTIMATOR_LOSS_CLIP's scales for r < 0 and r > 0, 1 unless set */
  uint8_t *mask;
};

/* Fails (INVALID_ARGUMENT, both boxes and indices named) unless the medium
 * has the box and indices the set was made for. */
hetinv_result_t hv_measurements_check_medium(const hetinv_context_t *ctx, const hetinv_measurements_t *set,
                                             const hetinv_medium_t *medium);

#endif
