/* The hemispherical sensor: the power leaving through a rectangle of a
 * face, in any direction (diffuse reflectance, total transmittance). One
 * value; scored where a photon leaves. */
#include <math.h>

#include "core/error.h"
#include "medium/medium_internal.h"
#include "sampling/sensor_internal.h"
#include "transport/score.h"
#include "transport/sensor_kind.h"

static void at_exit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_sensor_target_t *t,
                    const hv_exit_t *out, hv_tally_t *tally) {
  (void)tr;
  if (t->sensor->face != out->face || hv_sensor_pixel_at(t->sensor, out->ray->p) < 0) return;
  hv_path_log_t *log = tally->grad ? &tally->grad->path : NULL;
  hv_score(plan, t, tally, tally->values, log, 0, out->tau, out->w);
  if (out->scatterings == 0 && tally->ballistic) hv_score(plan, t, tally, tally->ballistic, log, 0, out->tau, out->w);
}

static const hv_sensor_kind_t HEMISPHERICAL = {.name = "hemispherical", .at_exit = at_exit};

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
  hetinv_result_t r = hv_sensor_new(medium, &HEMISPHERICAL, face, 0, &s);
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
  s->width = s->height = 1; /* the rectangle as one pixel */
  *out = s;
  return HETINV_SUCCESS;
}
