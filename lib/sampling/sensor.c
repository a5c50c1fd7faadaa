#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "medium/fresnel.h"
#include "medium/medium_internal.h"
#include "sampling/sensor_internal.h"

HETINV_API void hetinv_sensor_destroy(hetinv_sensor_t **sensor) {
  HV_API_ENTER();
  if (sensor == NULL || *sensor == NULL) return;
  hv_free((*sensor)->ctx, *sensor);
  *sensor = NULL;
}

static hetinv_result_t new_sensor(const hetinv_medium_t *medium,
                                  hv_sensor_kind_t kind, hetinv_face_t face,
                                  hetinv_sensor_t **out) {
  hetinv_result_t r = hv_check_face(medium->ctx, face);
  if (r != HETINV_SUCCESS) return r;
  hetinv_sensor_t *s = hv_calloc(medium->ctx, 1, sizeof *s);
  if (s == NULL) return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a sensor");
  s->ctx = medium->ctx;
  hv_geometry_of(medium, &s->geo);
  s->kind = kind;
  s->face = face;
  *out = s;
  return HETINV_SUCCESS;
}

/* The interior direction that refracts into s->dir_out, and the factors of
 * a next-event connection along it. */
static hetinv_result_t set_direction(hetinv_sensor_t *s, const double d[3]) {
  hetinv_result_t r = hv_normalize3(s->ctx, "direction", d, s->dir_out);
  if (r != HETINV_SUCCESS) return r;
  double n[3];
  hv_face_normal(s->face, n);
  double cos_out = s->dir_out[hv_face_axis(s->face)] * hv_face_sign(s->face);
  if (!(cos_out > 0.0)) {
    return HV_FAIL(s->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "direction (%g, %g, %g) points %s face %d; it must point away from the medium",
                   d[0], d[1], d[2], cos_out == 0.0 ? "along" : "into the medium through",
                   (int)s->face);
  }
  /* Follow the light backwards: from outside, along -dir_out, into the medium. */
  double back[3] = {-s->dir_out[0], -s->dir_out[1], -s->dir_out[2]}, back_in[3];
  if (!hv_refract(back, n, s->geo.eta / s->geo.eta_out, back_in)) {
    return HV_FAIL(s->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "no light from inside leaves face %d along (%g, %g, %g): with eta %g inside "
                   "and %g outside it lies beyond the critical angle", (int)s->face, d[0], d[1],
                   d[2], s->geo.eta, s->geo.eta_out);
  }
  for (int a = 0; a < 3; ++a) s->dir_in[a] = -back_in[a];
  double cos_in = fabs(s->dir_in[hv_face_axis(s->face)]), cos_t;
  double eta = s->geo.eta_out / s->geo.eta; /* leaving: η_t / η_i */
  double R = hv_fresnel_dielectric(cos_in, eta, &cos_t);
  double area = s->pixel_size[0] * s->pixel_size[1];
  s->connection_scale = hv_fresnel_radiance_scale(R, eta) / (cos_in * area);
  s->ballistic_scale = 1.0 / area;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_sensor_create_orthographic(
    const hetinv_medium_t *medium, hetinv_face_t face, const double direction[3],
    const double origin[2], const double pixel_size[2], int32_t width, int32_t height,
    hetinv_sensor_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  hetinv_context_t *ctx = medium->ctx;
  HV_CHECK_NULL(ctx, direction);
  HV_CHECK_NULL(ctx, origin);
  HV_CHECK_NULL(ctx, pixel_size);
  for (int i = 0; i < 2; ++i) {
    if (!isfinite(origin[i])) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "origin[%d] is %g; it must be finite", i, origin[i]);
    }
    if (!isfinite(pixel_size[i]) || !(pixel_size[i] > 0.0)) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "pixel_size[%d] is %g; it must be finite and > 0", i, pixel_size[i]);
    }
  }
  if (width <= 0 || height <= 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "the sensor is %d x %d pixels; each must be > 0",
                   (int)width, (int)height);
  }
  if ((int64_t)width * height > HETINV_MAX_SENSOR_PIXELS) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "width x height is %d x %d pixels; at most HETINV_MAX_SENSOR_PIXELS (%ld) in all",
                   (int)width, (int)height, (long)HETINV_MAX_SENSOR_PIXELS);
  }
  hetinv_sensor_t *s = NULL;
  hetinv_result_t r = new_sensor(medium, HV_SENSOR_ORTHOGRAPHIC, face, &s);
  if (r != HETINV_SUCCESS) return r;
  memcpy(s->origin, origin, sizeof s->origin);
  memcpy(s->pixel_size, pixel_size, sizeof s->pixel_size);
  s->width = width;
  s->height = height;
  r = set_direction(s, direction);
  if (r != HETINV_SUCCESS) {
    hetinv_sensor_destroy(&s);
    return r;
  }
  *out = s;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_sensor_create_hemispherical(const hetinv_medium_t *medium,
                                                              hetinv_face_t face,
                                                              const double rect_min[2],
                                                              const double rect_max[2],
                                                              hetinv_sensor_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  hetinv_context_t *ctx = medium->ctx;
  if ((rect_min == NULL) != (rect_max == NULL)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "rect_min is %s and rect_max is %s; give both or neither (whole face)",
                   rect_min ? "set" : "NULL", rect_max ? "set" : "NULL");
  }
  hetinv_sensor_t *s = NULL;
  hetinv_result_t r = new_sensor(medium, HV_SENSOR_HEMISPHERICAL, face, &s);
  if (r != HETINV_SUCCESS) return r;
  int ax[2];
  hv_face_uv_axes(face, &ax[0], &ax[1]);
  for (int i = 0; i < 2; ++i) {
    double lo = rect_min ? rect_min[i] : s->geo.lo[ax[i]];
    double hi = rect_max ? rect_max[i] : s->geo.hi[ax[i]];
    if (!isfinite(lo) || !isfinite(hi) || !(lo < hi)) {
      hetinv_sensor_destroy(&s);
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "the rectangle along %c is [%g, %g]; it must be finite with min < max",
                     "xyz"[ax[i]], lo, hi);
    }
    s->origin[i] = lo;
    s->pixel_size[i] = hi - lo;
  }
  s->width = s->height = 1;
  *out = s;
  return HETINV_SUCCESS;
}

HETINV_API int32_t hetinv_sensor_pixel_count(const hetinv_sensor_t *sensor) {
  HV_API_ENTER();
  return sensor ? sensor->width * sensor->height : 0;
}

HETINV_API hetinv_result_t hetinv_sensor_get_size(const hetinv_sensor_t *sensor, int32_t *width,
                                                  int32_t *height) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, sensor);
  if (width) *width = sensor->width;
  if (height) *height = sensor->height;
  return HETINV_SUCCESS;
}
