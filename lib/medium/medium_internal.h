/* The medium's fields, read directly by the transport code (never installed). */
#ifndef HV_MEDIUM_INTERNAL_H
#define HV_MEDIUM_INTERNAL_H

#include <stdbool.h>

#include "hetinv/medium.h"

struct hetinv_medium {
  hetinv_context_t *ctx;
  double box_min[3], box_max[3];
  int32_t dims[3];
  size_t voxel_count;
  double *values[HETINV_PARAM_COUNT]; /* σa, σs, g: voxel_count each, linear voxel order */
  double eta, eta_out;
  bool committed;
};

/* NULL if @p value is allowed for @p param, else the rule it breaks
 * ("it must be >= 0"), for the caller's message. */
const char *hv_medium_value_rule(hetinv_param_t param, double value);

/* Checks one value of voxel @p voxel (linear index); on failure records a
 * message naming the voxel and returns HETINV_ERROR_INVALID_ARGUMENT. */
hetinv_result_t hv_medium_check_voxel_value(const hetinv_medium_t *m,
                                            hetinv_param_t param, size_t voxel, double value);

#endif
