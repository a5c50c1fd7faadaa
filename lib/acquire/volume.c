#include <math.h>
#include <stdio.h>

#include "acquire/volume_internal.h"
#include "core/error.h"
#include "medium/medium_internal.h"

hetinv_result_t hv_volume_check_medium(const hetinv_medium_t *medium) {
  if (medium == NULL) return HV_FAIL(NULL, HETINV_ERROR_NULL_ARGUMENT, "'medium' is NULL");
  if (medium->committed) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_STATE,
                   "the medium is committed and immutable; generate into an uncommitted one "
                   "(hetinv_medium_clone)");
  }
  return HETINV_SUCCESS;
}

hetinv_result_t hv_volume_check_ranges(const hetinv_context_t *ctx,
                                       const double lo[3], const double hi[3]) {
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    const char *name = hetinv_param_name(p);
    const char *rule = hv_medium_value_rule(p, lo[p]);
    if (rule != NULL) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "spec->lo[%d] (%s) is %g; %s",
                     (int)p, name, lo[p], rule);
    }
    rule = hv_medium_value_rule(p, hi[p]);
    if (rule != NULL) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "spec->hi[%d] (%s) is %g; %s",
                     (int)p, name, hi[p], rule);
    }
    if (lo[p] > hi[p]) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "spec->lo[%d] (%s) is %g and spec->hi[%d] is %g; lo must be <= hi", (int)p,
                     name, lo[p], (int)p, hi[p]);
    }
  }
  return HETINV_SUCCESS;
}

double hv_volume_lerp(double lo, double hi, double t) {
  return fmin(fmax(lo * (1.0 - t) + hi * t, lo), hi);
}

hetinv_result_t hv_volume_store(hetinv_medium_t *medium, double *const values[3]) {
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    hetinv_result_t r = hetinv_medium_set_grid(medium, p, values[p], medium->voxel_count);
    if (r != HETINV_SUCCESS) { /* a bug: the values were checked before */
      char why[512];
      snprintf(why, sizeof why, "%s", hetinv_context_last_error_message(medium->ctx));
      return HV_FAIL(medium->ctx, HETINV_ERROR_INTERNAL,
                     "the generated %s was rejected by the medium: %s", hetinv_param_name(p), why);
    }
  }
  return HETINV_SUCCESS;
}
