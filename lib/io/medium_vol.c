/* One parameter of a medium from or to a 1-channel .vol file. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/vol_format.h"
#include "medium/medium_internal.h"

static hetinv_result_t check_param(const hetinv_context_t *ctx, hetinv_param_t param) {
  if (param >= 0 && param < HETINV_PARAM_COUNT) return HETINV_SUCCESS;
  return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_RANGE,
                 "param is %d; it must be HETINV_PARAM_SIGMA_A, _SIGMA_S or _G", (int)param);
}

static bool same_grid(const hetinv_vol_header_t *h, const hetinv_medium_t *m) {
  return h->channels == 1 && h->dims[0] == m->dims[0] && h->dims[1] == m->dims[1] &&
         h->dims[2] == m->dims[2];
}

static hetinv_result_t grid_mismatch(const hetinv_medium_t *m, const char *path,
                                     const hetinv_vol_header_t *h) {
  return HV_FAIL(m->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                 "'%s' holds %d x %d x %d voxels, channels %d; the medium needs %d x %d x %d "
                 "voxels, channels 1",
                 path, (int)h->dims[0], (int)h->dims[1], (int)h->dims[2], (int)h->channels,
                 (int)m->dims[0], (int)m->dims[1], (int)m->dims[2]);
}

/* Checks every value by the medium's rules (naming file and voxel), then
 * stores them all, so a failure leaves the medium unchanged. */
static hetinv_result_t store(hetinv_medium_t *m, const char *path,
                             hetinv_param_t param, const float *values) {
  size_t nx = (size_t)m->dims[0], ny = (size_t)m->dims[1];
  for (size_t i = 0; i < m->voxel_count; ++i) {
    const char *rule = hv_medium_value_rule(param, (double)values[i]);
    if (rule != NULL) {
      return HV_FAIL(m->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "'%s': %s of voxel (%zu, %zu, %zu) is %g; %s", path,
                     hetinv_param_name(param), i % nx, i / nx % ny, i / (nx * ny),
                     (double)values[i], rule);
    }
  }
  for (size_t i = 0; i < m->voxel_count; ++i) m->values[param][i] = (double)values[i];
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_read_vol(hetinv_medium_t *medium, hetinv_param_t param,
                                                  const char *path) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, medium);
  HV_CHECK_NULL(medium->ctx, path);
  if (medium->committed) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_STATE,
                   "the medium is committed and immutable; clone it to change it");
  }
  hetinv_result_t r = check_param(medium->ctx, param);
  if (r != HETINV_SUCCESS) return r;
  /* The header first, so a wrong grid fails before any allocation. */
  hetinv_vol_header_t h;
  r = hv_vol_read_file(medium->ctx, path, &h, NULL, 0);
  if (r != HETINV_SUCCESS) return r;
  if (!same_grid(&h, medium)) return grid_mismatch(medium, path, &h);
  float *values = hv_calloc(medium->ctx, medium->voxel_count, sizeof(float));
  if (values == NULL) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu floats",
                   medium->voxel_count);
  }
  r = hv_vol_read_file(medium->ctx, path, &h, values, medium->voxel_count);
  if (r == HETINV_SUCCESS && !same_grid(&h, medium)) { /* the file changed meanwhile */
    r = grid_mismatch(medium, path, &h);
  }
  if (r == HETINV_SUCCESS) r = store(medium, path, param, values);
  hv_free(medium->ctx, values);
  return r;
}

/* The float32 value written for @p v, which the medium's rules allow. */
static float to_float(hetinv_param_t param, double v) {
  float f = (float)v;
  /* Rounding may reach |g| = 1, which the reader would reject: stay inside. */
  if (param == HETINV_PARAM_G && f >= 1.0f) f = nextafterf(1.0f, 0.0f);
  if (param == HETINV_PARAM_G && f <= -1.0f) f = nextafterf(-1.0f, 0.0f);
  return f;
}

HETINV_API hetinv_result_t hetinv_medium_write_vol(const hetinv_medium_t *medium,
                                                   hetinv_param_t param, const char *path) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, medium);
  HV_CHECK_NULL(medium->ctx, path);
  hetinv_result_t r = check_param(medium->ctx, param);
  if (r != HETINV_SUCCESS) return r;
  size_t n = medium->voxel_count, nx = (size_t)medium->dims[0], ny = (size_t)medium->dims[1];
  float *values = hv_calloc(medium->ctx, n, sizeof(float));
  if (values == NULL) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu floats", n);
  }
  for (size_t i = 0; i < n; ++i) {
    double v = medium->values[param][i];
    if (!(fabs(v) <= (double)FLT_MAX)) {
      hv_free(medium->ctx, values);
      return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "%s of voxel (%zu, %zu, %zu) is %g; it does not fit in float32",
                     hetinv_param_name(param), i % nx, i / nx % ny, i / (nx * ny), v);
    }
    values[i] = to_float(param, v);
  }
  hetinv_vol_header_t h = {.channels = 1};
  memcpy(h.dims, medium->dims, sizeof h.dims);
  memcpy(h.box_min, medium->box_min, sizeof h.box_min);
  memcpy(h.box_max, medium->box_max, sizeof h.box_max);
  r = hv_vol_write_file(medium->ctx, path, &h, values, n);
  hv_free(medium->ctx, values);
  return r;
}
