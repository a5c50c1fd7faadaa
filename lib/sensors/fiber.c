/* The fiber probe: a disk of radius r centred on a face that accepts the
 * light leaving the medium through it within its numerical aperture NA,
 * i.e. along an outside direction at θ to the face's outward normal with
 * η_out·sin θ ≤ NA (η_out the medium's outside index). One value: power, as
 * the hemispherical sensor's; scored where a photon leaves. */
#include <math.h>

#include "core/error.h"
#include "core/hash.h"
#include "medium/medium_internal.h"
#include "sampling/sensor_internal.h"
#include "transport/score.h"
#include "transport/sensor_kind.h"

typedef struct fiber {
  double centre[2]; /* face coordinates (u, v) */
  double radius, numerical_aperture; /* as given, for the fingerprint */
  /* Derived: the disk test without a square root, and the acceptance cone
   * as the least cosine of the refracted (outside) exit direction, so the
   * exit hook compares the cosine it is handed (hv_exit_t::cos_t). */
  double radius_squared, min_cos_out;
} fiber_t;

static void at_exit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_sensor_target_t *t,
                    const hv_exit_t *out, hv_tally_t *tally) {
  (void)tr;
  const hetinv_sensor_t *s = t->sensor;
  const fiber_t *f = s->data;
  if (s->face != out->face || out->cos_t < f->min_cos_out) return;
  int au, av;
  hv_face_uv_axes(s->face, &au, &av);
  double du = out->ray->p[au] - f->centre[0], dv = out->ray->p[av] - f->centre[1];
  if (du * du + dv * dv > f->radius_squared) return;
  hv_path_log_t *log = tally->grad ? &tally->grad->path : NULL;
  hv_score(plan, t, tally, tally->values, log, 0, out->tau, out->w);
  if (out->scatterings == 0 && tally->ballistic) hv_score(plan, t, tally, tally->ballistic, log, 0, out->tau, out->w);
}

/* The pixel grid every sensor has (the disk's bounding square) already
 * holds the centre and radius to rounding; the arguments go in exactly. */
static uint64_t fingerprint(const hetinv_sensor_t *s, uint64_t h) {
  const fiber_t *f = s->data;
  h = hv_fnv1a(h, f->centre, sizeof f->centre);
  h = hv_fnv1a(h, &f->radius, sizeof f->radius);
  return hv_fnv1a(h, &f->numerical_aperture, sizeof f->numerical_aperture);
}

static const hv_sensor_kind_t FIBER = {.name = "fiber", .at_exit = at_exit, .fingerprint = fingerprint};

HETINV_API hetinv_result_t hetinv_sensor_create_fiber(const hetinv_medium_t *medium, hetinv_face_t face,
                                                      const double centre[2], double radius,
                                                      double numerical_aperture, hetinv_sensor_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  hetinv_context_t *ctx = medium->ctx;
  HV_CHECK_NULL(ctx, centre);
  if (!isfinite(radius) || !(radius > 0.0) || !isnormal(radius * radius)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "radius is %g; it must be finite and > 0, with a normal square (about 1e-154 to 1e154)",
                   radius);
  }
  if (!isfinite(numerical_aperture) || !(numerical_aperture > 0.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "numerical_aperture is %g; it must be finite and > 0 (at least the outside index %g "
                   "accepts every direction)", numerical_aperture, medium->eta_out);
  }
  hetinv_sensor_t *s = NULL;
  hetinv_result_t r = hv_sensor_new(medium, &FIBER, face, sizeof(fiber_t), &s);
  if (r != HETINV_SUCCESS) return r;
  int ax[2];
  hv_face_uv_axes(face, &ax[0], &ax[1]);
  fiber_t *f = s->data;
  for (int i = 0; i < 2; ++i) {
    double lo = s->geo.lo[ax[i]], hi = s->geo.hi[ax[i]];
    if (!(centre[i] >= lo && centre[i] <= hi)) {
      hetinv_sensor_destroy(&s);
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "centre[%d] (%c) is %g; it must lie on face %d, within [%g, %g]", i, "xyz"[ax[i]],
                     centre[i], (int)face, lo, hi);
    }
    f->centre[i] = centre[i];
    /* The disk's bounding square as the one pixel: what every sensor has
     * (its hash, and a centre for code that reads pixel centres). */
    s->origin[i] = centre[i] - radius;
    s->pixel_size[i] = 2.0 * radius;
  }
  s->width = s->height = 1;
  f->radius = radius;
  f->numerical_aperture = numerical_aperture;
  f->radius_squared = radius * radius;
  double sin_max = numerical_aperture / s->geo.eta_out;
  /* NA ≥ η_out: every outside direction (cos_t ≥ 0) is accepted. */
  f->min_cos_out = sin_max >= 1.0 ? -1.0 : sqrt((1.0 - sin_max) * (1.0 + sin_max));
  *out = s;
  return HETINV_SUCCESS;
}
