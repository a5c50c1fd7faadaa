#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "medium/medium_internal.h"

HETINV_API const char *hetinv_param_name(hetinv_param_t param) {
  HV_API_ENTER();
  switch (param) {
    case HETINV_PARAM_SIGMA_A: return "sigma_a";
    case HETINV_PARAM_SIGMA_S: return "sigma_s";
    case HETINV_PARAM_G: return "g";
    default: return "unknown";
  }
}

const char *hv_medium_value_rule(hetinv_param_t param, double value) {
  if (!isfinite(value)) return "it must be finite";
  if (param == HETINV_PARAM_G) return value > -1.0 && value < 1.0 ? NULL : "it must satisfy -1 < g < 1";
  return value >= 0.0 ? NULL : "it must be >= 0";
}

hetinv_result_t hv_medium_check_voxel_value(const hetinv_medium_t *m,
                                            hetinv_param_t param, size_t voxel, double value) {
  const char *rule = hv_medium_value_rule(param, value);
  if (rule == NULL) return HETINV_SUCCESS;
  size_t nx = (size_t)m->dims[0], ny = (size_t)m->dims[1];
  return HV_FAIL(m->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                 "%s of voxel (%zu, %zu, %zu) is %g; %s", hetinv_param_name(param), voxel % nx,
                 (voxel / nx) % ny, voxel / (nx * ny), value, rule);
}

static void free_values(hetinv_medium_t *m) {
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    hv_free(m->ctx, m->values[p]);
    m->values[p] = NULL;
  }
}

/* Allocates a zeroed medium with the given geometry; no validation. */
static hetinv_result_t allocate(hetinv_context_t *ctx, const double box_min[3],
                                const double box_max[3], const int32_t dims[3], size_t voxels,
                                hetinv_medium_t **out) {
  hetinv_medium_t *m = hv_calloc(ctx, 1, sizeof *m);
  if (m == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a medium");
  m->ctx = ctx;
  memcpy(m->box_min, box_min, sizeof m->box_min);
  memcpy(m->box_max, box_max, sizeof m->box_max);
  memcpy(m->dims, dims, sizeof m->dims);
  m->voxel_count = voxels;
  m->eta = m->eta_out = 1.0;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    m->values[p] = hv_calloc(ctx, voxels, sizeof(double));
    if (m->values[p] == NULL) {
      free_values(m);
      hv_free(ctx, m);
      return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                     "cannot allocate %zu voxels of %s", voxels, hetinv_param_name(p));
    }
  }
  *out = m;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_create(hetinv_context_t *ctx, const double box_min[3],
                                                const double box_max[3], const int32_t dims[3],
                                                hetinv_medium_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, box_min);
  HV_CHECK_NULL(ctx, box_max);
  HV_CHECK_NULL(ctx, dims);
  static const char axis[3] = {'x', 'y', 'z'};
  size_t voxels = 1;
  for (int i = 0; i < 3; ++i) {
    if (!isfinite(box_min[i]) || !isfinite(box_max[i])) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "the box along %c is [%g, %g]; both ends must be finite", axis[i], box_min[i],
                     box_max[i]);
    }
    if (!(box_min[i] < box_max[i])) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "the box along %c is [%g, %g]; box_min must be < box_max", axis[i],
                     box_min[i], box_max[i]);
    }
    if (dims[i] <= 0) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "dims[%d] (n%c) is %d; it must be > 0",
                     i, axis[i], (int)dims[i]);
    }
  }
  for (int i = 0; i < 3; ++i) {
    if (!hv_mul_size(voxels, (size_t)dims[i], &voxels) || voxels > (size_t)HETINV_MAX_VOXELS) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "dims is %d x %d x %d voxels; at most HETINV_MAX_VOXELS (%ld) in all",
                     (int)dims[0], (int)dims[1], (int)dims[2], (long)HETINV_MAX_VOXELS);
    }
  }
  size_t bytes;
  if (!hv_mul_size(voxels, HETINV_PARAM_COUNT * sizeof(double), &bytes)) {
    return HV_FAIL(ctx, HETINV_ERROR_SIZE_OVERFLOW,
                   "%d x %d x %d voxels of 3 doubles overflow size_t", (int)dims[0],
                   (int)dims[1], (int)dims[2]);
  }
  return allocate(ctx, box_min, box_max, dims, voxels, out);
}

HETINV_API hetinv_result_t hetinv_medium_clone(const hetinv_medium_t *src, hetinv_medium_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(src ? src->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, src);
  hetinv_medium_t *m = NULL;
  hetinv_result_t r =
      allocate(src->ctx, src->box_min, src->box_max, src->dims, src->voxel_count, &m);
  if (r != HETINV_SUCCESS) return r;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    memcpy(m->values[p], src->values[p], src->voxel_count * sizeof(double));
  }
  m->eta = src->eta;
  m->eta_out = src->eta_out;
  *out = m;
  return HETINV_SUCCESS;
}

HETINV_API void hetinv_medium_destroy(hetinv_medium_t **medium) {
  HV_API_ENTER();
  if (medium == NULL || *medium == NULL) return;
  hetinv_medium_t *m = *medium;
  free_values(m);
  hv_free(m->ctx, m);
  *medium = NULL;
}

/* Common guard of every setter. */
static hetinv_result_t check_mutable(const hetinv_medium_t *m) {
  if (m == NULL) return HV_FAIL(NULL, HETINV_ERROR_NULL_ARGUMENT, "'medium' is NULL");
  if (m->committed) {
    return HV_FAIL(m->ctx, HETINV_ERROR_INVALID_STATE,
                   "the medium is committed and immutable; clone it to change it");
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_set_ior(hetinv_medium_t *medium, double eta,
                                                 double eta_out) {
  HV_API_ENTER();
  hetinv_result_t r = check_mutable(medium);
  if (r != HETINV_SUCCESS) return r;
  if (!isfinite(eta) || eta <= 0.0) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "eta (inside) is %g; it must be finite and > 0", eta);
  }
  if (!isfinite(eta_out) || eta_out <= 0.0) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "eta_out (outside) is %g; it must be finite and > 0", eta_out);
  }
  /* A ratio that underflowed to 0 (1e-200 / 1e200) tripped Fresnel's
   * assertion in a render. */
  double ratio = eta / eta_out;
  if (!(ratio >= 1.0 / HETINV_MAX_RELATIVE_IOR && ratio <= HETINV_MAX_RELATIVE_IOR)) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "eta / eta_out is %g / %g = %g; the relative index must be within [%g, %g]", eta, eta_out,
                   ratio, 1.0 / HETINV_MAX_RELATIVE_IOR, HETINV_MAX_RELATIVE_IOR);
  }
  medium->eta = eta;
  medium->eta_out = eta_out;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_fill(hetinv_medium_t *medium, double sigma_a,
                                              double sigma_s, double g) {
  HV_API_ENTER();
  hetinv_result_t r = check_mutable(medium);
  const double v[HETINV_PARAM_COUNT] = {sigma_a, sigma_s, g};
  if (r != HETINV_SUCCESS) return r;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    const char *rule = hv_medium_value_rule(p, v[p]);
    if (rule != NULL) {
      return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT, "%s is %g; %s",
                     hetinv_param_name(p), v[p], rule);
    }
  }
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    for (size_t i = 0; i < medium->voxel_count; ++i) medium->values[p][i] = v[p];
  }
  return HETINV_SUCCESS;
}

/* Linear index of (ix, iy, iz), or an OUT_OF_RANGE failure naming it. */
static hetinv_result_t voxel_index(const hetinv_medium_t *m, int32_t ix,
                                   int32_t iy, int32_t iz, size_t *index) {
  if (ix < 0 || iy < 0 || iz < 0 || ix >= m->dims[0] || iy >= m->dims[1] || iz >= m->dims[2]) {
    return HV_FAIL(m->ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "voxel (%d, %d, %d) is outside the %d x %d x %d grid", (int)ix, (int)iy,
                   (int)iz, (int)m->dims[0], (int)m->dims[1], (int)m->dims[2]);
  }
  *index = (size_t)ix + (size_t)m->dims[0] * ((size_t)iy + (size_t)m->dims[1] * (size_t)iz);
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_set_voxel(hetinv_medium_t *medium, int32_t ix,
                                                   int32_t iy, int32_t iz, double sigma_a,
                                                   double sigma_s, double g) {
  HV_API_ENTER();
  hetinv_result_t r = check_mutable(medium);
  size_t k = 0;
  if (r == HETINV_SUCCESS) r = voxel_index(medium, ix, iy, iz, &k);
  const double v[HETINV_PARAM_COUNT] = {sigma_a, sigma_s, g};
  for (int p = 0; r == HETINV_SUCCESS && p < HETINV_PARAM_COUNT; ++p) {
    r = hv_medium_check_voxel_value(medium, p, k, v[p]);
  }
  if (r != HETINV_SUCCESS) return r;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) medium->values[p][k] = v[p];
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_set_grid(hetinv_medium_t *medium, hetinv_param_t param,
                                                  const double *values, size_t count) {
  HV_API_ENTER();
  hetinv_result_t r = check_mutable(medium);
  if (r != HETINV_SUCCESS) return r;
  HV_CHECK_NULL(medium->ctx, values);
  if (param < 0 || param >= HETINV_PARAM_COUNT) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "param is %d; it must be HETINV_PARAM_SIGMA_A, _SIGMA_S or _G", (int)param);
  }
  if (count != medium->voxel_count) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "count is %zu; the %d x %d x %d grid has %zu voxels", count,
                   (int)medium->dims[0], (int)medium->dims[1], (int)medium->dims[2],
                   medium->voxel_count);
  }
  for (size_t i = 0; i < count; ++i) {
    r = hv_medium_check_voxel_value(medium, param, i, values[i]);
    if (r != HETINV_SUCCESS) return r;
  }
  memcpy(medium->values[param], values, count * sizeof(double));
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_commit(hetinv_medium_t *medium) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, medium);
  medium->committed = true;
  return HETINV_SUCCESS;
}

HETINV_API int hetinv_medium_is_committed(const hetinv_medium_t *medium) {
  HV_API_ENTER();
  return medium != NULL && medium->committed;
}

HETINV_API hetinv_context_t *hetinv_medium_context(const hetinv_medium_t *medium) {
  HV_API_ENTER();
  return medium ? medium->ctx : NULL;
}

HETINV_API hetinv_result_t hetinv_medium_get_dims(const hetinv_medium_t *medium, int32_t dims[3]) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, medium);
  HV_CHECK_NULL(medium->ctx, dims);
  memcpy(dims, medium->dims, sizeof medium->dims);
  return HETINV_SUCCESS;
}

HETINV_API size_t hetinv_medium_voxel_count(const hetinv_medium_t *medium) {
  HV_API_ENTER();
  return medium ? medium->voxel_count : 0;
}

HETINV_API hetinv_result_t hetinv_medium_get_box(const hetinv_medium_t *medium, double box_min[3],
                                                 double box_max[3]) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, medium);
  if (box_min) memcpy(box_min, medium->box_min, sizeof medium->box_min);
  if (box_max) memcpy(box_max, medium->box_max, sizeof medium->box_max);
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_get_ior(const hetinv_medium_t *medium, double *eta,
                                                 double *eta_out) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, medium);
  if (eta) *eta = medium->eta;
  if (eta_out) *eta_out = medium->eta_out;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_medium_get_voxel(const hetinv_medium_t *medium, int32_t ix,
                                                   int32_t iy, int32_t iz, double *sigma_a,
                                                   double *sigma_s, double *g) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, medium);
  size_t k = 0;
  hetinv_result_t r = voxel_index(medium, ix, iy, iz, &k);
  if (r != HETINV_SUCCESS) return r;
  if (sigma_a) *sigma_a = medium->values[HETINV_PARAM_SIGMA_A][k];
  if (sigma_s) *sigma_s = medium->values[HETINV_PARAM_SIGMA_S][k];
  if (g) *g = medium->values[HETINV_PARAM_G][k];
  return HETINV_SUCCESS;
}

HETINV_API const double *hetinv_medium_grid(const hetinv_medium_t *medium, hetinv_param_t param) {
  HV_API_ENTER();
  if (medium == NULL || param < 0 || param >= HETINV_PARAM_COUNT) return NULL;
  return medium->values[param];
}
