/* Estimator handle and its tunables. The render itself is in render.c. */
#include <math.h>
#include <stddef.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "estimator/estimator_internal.h"
#include "estimator/grad_scratch.h"
#include "transport/grid_store.h"

/* Bounds, defaults and integrality of each tunable, indexed by enum value. */
static const struct {
  const char *name;
  double lo, hi, fallback;
  bool integer;
} params[HETINV_ESTIMATOR_PARAM_COUNT_] = {
    [HETINV_ESTIMATOR_PHOTONS] = {"HETINV_ESTIMATOR_PHOTONS", 1, 281474976710655.0 /* 2^48-1 */, 100000, true},
    [HETINV_ESTIMATOR_BATCHES] = {"HETINV_ESTIMATOR_BATCHES", 2, 65536, 64, true},
    [HETINV_ESTIMATOR_ROULETTE_WEIGHT] = {"HETINV_ESTIMATOR_ROULETTE_WEIGHT", 0, 1, 1e-4, false},
    [HETINV_ESTIMATOR_ROULETTE_SURVIVAL] = {"HETINV_ESTIMATOR_ROULETTE_SURVIVAL", 1e-6, 1, 0.1, false},
    [HETINV_ESTIMATOR_MIN_SCATTERING] = {"HETINV_ESTIMATOR_MIN_SCATTERING", 0, 1e9, 0, true},
    [HETINV_ESTIMATOR_MAX_SCATTERING] = {"HETINV_ESTIMATOR_MAX_SCATTERING", 0, 1e9,
                                        HETINV_ESTIMATOR_DEFAULT_MAX_SCATTERING, true},
    [HETINV_ESTIMATOR_STREAM] = {"HETINV_ESTIMATOR_STREAM", 0, 65535, 0, true},
    [HETINV_ESTIMATOR_EPOCH] = {"HETINV_ESTIMATOR_EPOCH", 0, 9007199254740992.0 /* 2^53 */, 0, true},
    [HETINV_ESTIMATOR_LOSS_CLIP] = {"HETINV_ESTIMATOR_LOSS_CLIP", 0, 1e6, 0, false},
};

const char *hv_estimator_param_name(hetinv_estimator_param_t param) {
  return param >= 0 && param < HETINV_ESTIMATOR_PARAM_COUNT_ ? params[param].name : "an unknown tunable";
}

HETINV_API hetinv_result_t hetinv_estimator_create(hetinv_context_t *ctx, hetinv_estimator_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  hetinv_estimator_t *e = hv_calloc(ctx, 1, sizeof *e);
  if (e == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate an estimator");
  e->ctx = ctx;
  e->grad_scratch = hv_calloc(ctx, 1, sizeof *e->grad_scratch);
  e->grid_store = hv_calloc(ctx, 1, sizeof *e->grid_store);
  if (e->grad_scratch == NULL || e->grid_store == NULL) {
    hv_free(ctx, e->grad_scratch);
    hv_free(ctx, e->grid_store);
    hv_free(ctx, e);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate an estimator");
  }
  for (int i = 0; i < HETINV_ESTIMATOR_PARAM_COUNT_; ++i) e->param[i] = params[i].fallback;
  *out = e;
  return HETINV_SUCCESS;
}

HETINV_API void hetinv_estimator_destroy(hetinv_estimator_t **estimator) {
  HV_API_ENTER();
  if (estimator == NULL || *estimator == NULL) return;
  hv_free((*estimator)->ctx, (*estimator)->gains);
  hv_grad_scratch_release((*estimator)->ctx, (*estimator)->grad_scratch);
  hv_free((*estimator)->ctx, (*estimator)->grad_scratch);
  hv_grid_store_release((*estimator)->ctx, (*estimator)->grid_store);
  hv_free((*estimator)->ctx, (*estimator)->grid_store);
  hv_free((*estimator)->ctx, *estimator);
  *estimator = NULL;
}

static bool known(hetinv_estimator_param_t p) { return p >= 0 && p < HETINV_ESTIMATOR_PARAM_COUNT_; }

HETINV_API hetinv_result_t hetinv_estimator_param_bounds(hetinv_estimator_param_t param,
                                                         double *lo, double *hi) {
  HV_API_ENTER();
  if (!known(param)) {
    return HV_FAIL(NULL, HETINV_ERROR_OUT_OF_RANGE, "param %d is not an estimator parameter", (int)param);
  }
  if (lo) *lo = params[param].lo;
  if (hi) *hi = params[param].hi;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_estimator_set_param(hetinv_estimator_t *estimator,
                                                      hetinv_estimator_param_t param,
                                                      double value) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, estimator);
  if (!known(param)) {
    return HV_FAIL(estimator->ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "param %d is not an estimator parameter", (int)param);
  }
  if (!(value >= params[param].lo && value <= params[param].hi) ||
      (params[param].integer && value != floor(value))) {
    return HV_FAIL(estimator->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "%s is %.17g; it must be %s in [%.17g, %.17g]", params[param].name, value,
                   params[param].integer ? "an integer" : "a number", params[param].lo,
                   params[param].hi);
  }
  estimator->param[param] = value;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_estimator_get_param(const hetinv_estimator_t *estimator,
                                                      hetinv_estimator_param_t param,
                                                      double *value) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, estimator);
  HV_CHECK_NULL(estimator->ctx, value);
  if (!known(param)) {
    return HV_FAIL(estimator->ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "param %d is not an estimator parameter", (int)param);
  }
  *value = estimator->param[param];
  return HETINV_SUCCESS;
}

/* The first published hetinv_render_stats_t ends with `truncated`. */
#define HV_STATS_V1_SIZE (offsetof(hetinv_render_stats_t, truncated) + sizeof(double))

HETINV_API hetinv_result_t hetinv_estimator_get_stats(const hetinv_estimator_t *estimator,
                                                      hetinv_render_stats_t *stats) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, estimator);
  HV_CHECK_NULL(estimator->ctx, stats);
  if (stats->size < HV_STATS_V1_SIZE) {
    return HV_FAIL(estimator->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "stats->size is %zu; it must be at least %zu (the first version of "
                   "hetinv_render_stats_t; set it to sizeof(hetinv_render_stats_t))",
                   stats->size, (size_t)HV_STATS_V1_SIZE);
  }
  if (!estimator->has_stats) {
    return HV_FAIL(estimator->ctx, HETINV_ERROR_INVALID_STATE, "nothing has been rendered yet");
  }
  size_t size = stats->size < sizeof *stats ? stats->size : sizeof *stats;
  memcpy(stats, &estimator->stats, size);
  stats->size = size;
  return HETINV_SUCCESS;
}
