#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "sampling/emitter_internal.h"
#include "sampling/measurements_internal.h"
#include "sampling/pathlength_internal.h"
#include "sampling/sensor_internal.h"

HETINV_API hetinv_result_t hetinv_measurements_create(hetinv_context_t *ctx,
                                                      hetinv_measurements_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  hetinv_measurements_t *m = hv_calloc(ctx, 1, sizeof *m);
  if (m == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate");
  m->ctx = ctx;
  *out = m;
  return HETINV_SUCCESS;
}

static void free_arrays(hetinv_measurements_t *m) {
  hv_free(m->ctx, m->values);
  hv_free(m->ctx, m->std_errors);
  hv_free(m->ctx, m->weights);
  hv_free(m->ctx, m->clip_below);
  hv_free(m->ctx, m->clip_above);
  hv_free(m->ctx, m->mask);
}

HETINV_API void hetinv_measurements_destroy(hetinv_measurements_t **set) {
  HV_API_ENTER();
  if (set == NULL || *set == NULL) return;
  hetinv_measurements_t *m = *set;
  free_arrays(m);
  hv_free(m->ctx, m->rows);
  hv_free(m->ctx, m);
  *set = NULL;
}

/* Grows the value arrays to hold at least @p need values (new ones: value 0,
 * error 0, weight 1, clip scales 1, used). */
static hetinv_result_t reserve_values(hetinv_measurements_t *m, size_t need) {
  if (need <= m->value_capacity) return HETINV_SUCCESS;
  size_t cap = m->value_capacity ? m->value_capacity : 64;
  while (cap < need) cap = cap > ((size_t)-1) / 2 ? need : cap * 2;
  double *v = hv_calloc(m->ctx, cap, sizeof(double));
  double *e = hv_calloc(m->ctx, cap, sizeof(double));
  double *w = hv_calloc(m->ctx, cap, sizeof(double));
  double *cb = hv_calloc(m->ctx, cap, sizeof(double));
  double *ca = hv_calloc(m->ctx, cap, sizeof(double));
  uint8_t *k = hv_calloc(m->ctx, cap, 1);
  if (!v || !e || !w || !cb || !ca || !k) {
    hv_free(m->ctx, v), hv_free(m->ctx, e), hv_free(m->ctx, w), hv_free(m->ctx, k);
    hv_free(m->ctx, cb), hv_free(m->ctx, ca);
    return HV_FAIL(m->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu values", cap);
  }
  if (m->value_count > 0) {
    memcpy(v, m->values, m->value_count * sizeof(double));
    memcpy(e, m->std_errors, m->value_count * sizeof(double));
    memcpy(w, m->weights, m->value_count * sizeof(double));
    memcpy(cb, m->clip_below, m->value_count * sizeof(double));
    memcpy(ca, m->clip_above, m->value_count * sizeof(double));
    memcpy(k, m->mask, m->value_count);
  }
  free_arrays(m);
  m->values = v, m->std_errors = e, m->weights = w, m->mask = k;
  m->clip_below = cb, m->clip_above = ca;
  m->value_capacity = cap;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_measurements_add(hetinv_measurements_t *set,
                                                   const hetinv_emitter_t *emitter,
                                                   const hetinv_sensor_t *sensor,
                                                   const hetinv_pathlength_t *pathlength,
                                                   int32_t *row) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, set);
  HV_CHECK_NULL(set->ctx, emitter);
  HV_CHECK_NULL(set->ctx, sensor);
  HV_CHECK_NULL(set->ctx, pathlength);
  const hv_geometry_t *ref = set->row_count > 0 ? &set->geo : &emitter->geo;
  const char *odd = !hv_geometry_equal(ref, &emitter->geo) ? "emitter"
                    : !hv_geometry_equal(ref, &sensor->geo) ? "sensor" : NULL;
  if (odd != NULL) {
    double mine, theirs;
    const char *what = hv_geometry_first_difference(odd[0] == 'e' ? &emitter->geo : &sensor->geo, ref, &mine, &theirs);
    return HV_FAIL(set->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the %s was created from a medium whose box or refractive indices differ "
                   "from those of %s (%s %.17g against %.17g); a measurement set must not mix media", odd,
                   set->row_count > 0 ? "the set's earlier rows" : "the row's emitter", what, mine, theirs);
  }
  if (set->row_count >= HETINV_MAX_MEASUREMENT_ROWS) {
    return HV_FAIL(set->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the set already has %d rows, HETINV_MAX_MEASUREMENT_ROWS", (int)set->row_count);
  }
  /* pixels ≤ 2^24 and bins ≤ 2^16: the product fits in size_t, and so
   * does the sum with a value count ≤ 2^26. */
  size_t n = (size_t)hetinv_sensor_pixel_count(sensor) * (size_t)pathlength->count;
  size_t total = set->value_count + n;
  if (total > (size_t)HETINV_MAX_MEASUREMENT_VALUES) {
    return HV_FAIL(set->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the row's %d pixels x %d bins would give the set %zu values; at most "
                   "HETINV_MAX_MEASUREMENT_VALUES (%lld)", (int)hetinv_sensor_pixel_count(sensor),
                   (int)pathlength->count, total, (long long)HETINV_MAX_MEASUREMENT_VALUES);
  }
  if (set->row_count == set->row_capacity) {
    int32_t cap = set->row_capacity ? (set->row_capacity > INT32_MAX / 2 ? INT32_MAX : 2 * set->row_capacity) : 16;
    hv_row_t *rows = hv_calloc(set->ctx, (size_t)cap, sizeof *rows);
    if (rows == NULL) return HV_FAIL(set->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %d rows", (int)cap);
    if (set->row_count) memcpy(rows, set->rows, (size_t)set->row_count * sizeof *rows);
    hv_free(set->ctx, set->rows);
    set->rows = rows;
    set->row_capacity = cap;
  }
  hetinv_result_t r = reserve_values(set, total);
  if (r != HETINV_SUCCESS) return r;
  for (size_t i = set->value_count; i < total; ++i) {
    set->weights[i] = 1.0;
    set->clip_below[i] = set->clip_above[i] = 1.0;
    set->mask[i] = 1;
  }
  if (set->row_count == 0) set->geo = emitter->geo;
  set->rows[set->row_count] = (hv_row_t){emitter, sensor, pathlength, set->value_count,
                                         hetinv_sensor_pixel_count(sensor), pathlength->count};
  if (row) *row = set->row_count;
  set->row_count++;
  set->value_count = total;
  return HETINV_SUCCESS;
}

HETINV_API int32_t hetinv_measurements_row_count(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set ? set->row_count : 0;
}

HETINV_API size_t hetinv_measurements_value_count(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set ? set->value_count : 0;
}

HETINV_API hetinv_result_t hetinv_measurements_row_layout(const hetinv_measurements_t *set,
                                                          int32_t row, size_t *offset,
                                                          int32_t *pixels, int32_t *bins) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, set);
  if (row < 0 || row >= set->row_count) {
    return HV_FAIL(set->ctx, HETINV_ERROR_OUT_OF_RANGE, "row %d does not exist; the set has %d rows",
                   (int)row, (int)set->row_count);
  }
  const hv_row_t *r = &set->rows[row];
  if (offset) *offset = r->offset;
  if (pixels) *pixels = r->pixels;
  if (bins) *bins = r->bins;
  return HETINV_SUCCESS;
}

/* Row, pixel and bin of value index i, for messages. */
static void locate(const hetinv_measurements_t *m, size_t i, int *row, int *pixel, int *bin) {
  int32_t r = 0;
  while (r + 1 < m->row_count && m->rows[r + 1].offset <= i) ++r;
  size_t k = i - m->rows[r].offset;
  *row = r;
  *pixel = (int)(k % (size_t)m->rows[r].pixels);
  *bin = (int)(k / (size_t)m->rows[r].pixels);
}

/* What check_array() accepts beyond finite values. */
typedef enum { ANY_FINITE, NONNEGATIVE, POSITIVE } sign_t;

/* Checks count and that every value of a (if not NULL) is finite and of
 * the sign asked. */
static hetinv_result_t check_array(const hetinv_measurements_t *m,
                                   const char *what, const double *a, size_t count, sign_t sign) {
  if (count != m->value_count) {
    return HV_FAIL(m->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "count is %zu; the set has %zu values", count, m->value_count);
  }
  for (size_t i = 0; a && i < count; ++i) {
    if (!isfinite(a[i]) || (sign == NONNEGATIVE && a[i] < 0.0) || (sign == POSITIVE && !(a[i] > 0.0))) {
      int row, pixel, bin;
      locate(m, i, &row, &pixel, &bin);
      static const char *const limit[] = {"", " and >= 0", " and > 0"};
      return HV_FAIL(m->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "%s[%zu] (row %d, pixel %d, bin %d) is %g; it must be finite%s", what, i,
                     row, pixel, bin, a[i], limit[sign]);
    }
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_measurements_set_values(hetinv_measurements_t *set,
                                                          const double *values,
                                                          const double *std_errors, size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, set);
  HV_CHECK_NULL(set->ctx, values);
  hetinv_result_t r = check_array(set, "values", values, count, ANY_FINITE);
  if (r == HETINV_SUCCESS && std_errors) r = check_array(set, "std_errors", std_errors, count, NONNEGATIVE);
  if (r != HETINV_SUCCESS || count == 0) return r;
  memcpy(set->values, values, count * sizeof(double));
  if (std_errors) {
    memcpy(set->std_errors, std_errors, count * sizeof(double));
  } else {
    memset(set->std_errors, 0, count * sizeof(double));
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_measurements_set_weights(hetinv_measurements_t *set,
                                                           const double *weights, size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, set);
  HV_CHECK_NULL(set->ctx, weights);
  hetinv_result_t r = check_array(set, "weights", weights, count, NONNEGATIVE);
  if (r == HETINV_SUCCESS && count > 0) memcpy(set->weights, weights, count * sizeof(double));
  return r;
}

HETINV_API hetinv_result_t hetinv_measurements_set_clip_scales(hetinv_measurements_t *set, const double *below,
                                                               const double *above, size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, set);
  hetinv_result_t r = check_array(set, "below", below, count, POSITIVE);
  if (r == HETINV_SUCCESS) r = check_array(set, "above", above, count, POSITIVE);
  for (size_t i = 0; r == HETINV_SUCCESS && i < count; ++i) {
    set->clip_below[i] = below ? below[i] : 1.0;
    set->clip_above[i] = above ? above[i] : 1.0;
  }
  return r;
}

HETINV_API hetinv_result_t hetinv_measurements_set_mask(hetinv_measurements_t *set,
                                                        const uint8_t *mask, size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, set);
  HV_CHECK_NULL(set->ctx, mask);
  if (count != set->value_count) {
    return HV_FAIL(set->ctx, HETINV_ERROR_INVALID_ARGUMENT, "count is %zu; the set has %zu values",
                   count, set->value_count);
  }
  if (count > 0) memcpy(set->mask, mask, count);
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_measurements_mask_saturated(hetinv_measurements_t *set,
                                                              double level, size_t *masked) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, set);
  if (isnan(level)) {
    return HV_FAIL(set->ctx, HETINV_ERROR_INVALID_ARGUMENT, "level is %g; it must not be NaN", level);
  }
  size_t n = 0;
  for (size_t i = 0; i < set->value_count; ++i) {
    if (set->values[i] >= level) {
      set->mask[i] = 0;
      ++n;
    }
  }
  if (masked) *masked = n;
  return HETINV_SUCCESS;
}

HETINV_API const double *hetinv_measurements_values(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set && set->value_count ? set->values : NULL;
}
HETINV_API const double *hetinv_measurements_std_errors(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set && set->value_count ? set->std_errors : NULL;
}
HETINV_API const double *hetinv_measurements_weights(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set && set->value_count ? set->weights : NULL;
}
HETINV_API const double *hetinv_measurements_clip_scales_below(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set && set->value_count ? set->clip_below : NULL;
}
HETINV_API const double *hetinv_measurements_clip_scales_above(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set && set->value_count ? set->clip_above : NULL;
}
HETINV_API const uint8_t *hetinv_measurements_mask(const hetinv_measurements_t *set) {
  HV_API_ENTER();
  return set && set->value_count ? set->mask : NULL;
}

hetinv_result_t hv_measurements_check_medium(const hetinv_context_t *ctx, const hetinv_measurements_t *set,
                                             const hetinv_medium_t *medium) {
  hv_geometry_t geo;
  hv_geometry_of(medium, &geo);
  double mine, theirs;
  const char *what = hv_geometry_first_difference(&geo, &set->geo, &mine, &theirs);
  if (what == NULL) return HETINV_SUCCESS;
  return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                 "the medium's box [%g, %g] x [%g, %g] x [%g, %g] with eta %g / %g differs from "
                 "the box [%g, %g] x [%g, %g] x [%g, %g] with eta %g / %g the set was made for "
                 "(its %s is %.17g, the set's %.17g)",
                 geo.lo[0], geo.hi[0], geo.lo[1], geo.hi[1], geo.lo[2], geo.hi[2], geo.eta, geo.eta_out,
                 set->geo.lo[0], set->geo.hi[0], set->geo.lo[1], set->geo.hi[1], set->geo.lo[2], set->geo.hi[2],
                 set->geo.eta, set->geo.eta_out, what, mine, theirs);
}
