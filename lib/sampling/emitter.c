#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "medium/medium_internal.h"
#include "medium/phase.h"
#include "sampling/emitter_internal.h"

static hetinv_result_t new_emitter(const hetinv_medium_t *medium,
                                   hv_emitter_kind_t kind, hetinv_emitter_t **out) {
  hetinv_emitter_t *e = hv_calloc(medium->ctx, 1, sizeof *e);
  if (e == NULL) return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate an emitter");
  e->ctx = medium->ctx;
  hv_geometry_of(medium, &e->geo);
  e->kind = kind;
  e->power = 1.0;
  *out = e;
  return HETINV_SUCCESS;
}

HETINV_API void hetinv_emitter_destroy(hetinv_emitter_t **emitter) {
  HV_API_ENTER();
  if (emitter == NULL || *emitter == NULL) return;
  hetinv_emitter_t *e = *emitter;
  hv_free(e->ctx, e->points);
  hv_free(e->ctx, e->faces);
  hv_free(e->ctx, e->directions);
  hv_free(e->ctx, e->cdf);
  hv_free(e->ctx, e);
  *emitter = NULL;
}

/* Entry point and face of beam (origin, direction); fails naming the beam. */
static hetinv_result_t place_beam(const hetinv_emitter_t *e, int32_t index,
                                  const double origin[3], const double direction[3],
                                  double point[3], hetinv_face_t *face, double unit[3]) {
  char what[64], which[32] = "";
  if (index >= 0) snprintf(which, sizeof which, " of source %d", (int)index);
  snprintf(what, sizeof what, "direction%s", which);
  hetinv_result_t r = hv_normalize3(e->ctx, what, direction, unit);
  if (r != HETINV_SUCCESS) return r;
  if (!isfinite(origin[0]) || !isfinite(origin[1]) || !isfinite(origin[2])) {
    return HV_FAIL(e->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "origin%s is (%g, %g, %g); it must be finite", which, origin[0], origin[1],
                   origin[2]);
  }
  bool inside = true;
  for (int a = 0; a < 3; ++a) inside = inside && origin[a] > e->geo.lo[a] && origin[a] < e->geo.hi[a];
  if (inside) {
    return HV_FAIL(e->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "origin%s (%g, %g, %g) is inside the box; light must come from outside "
                   "or from the boundary", which, origin[0], origin[1], origin[2]);
  }
  double t;
  if (!hv_ray_enter_box(&e->geo, origin, unit, &t, face)) {
    return HV_FAIL(e->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the beam%s from (%g, %g, %g) along (%g, %g, %g) misses the box "
                   "[%g, %g] x [%g, %g] x [%g, %g]", which, origin[0], origin[1], origin[2],
                   direction[0], direction[1], direction[2], e->geo.lo[0], e->geo.hi[0],
                   e->geo.lo[1], e->geo.hi[1], e->geo.lo[2], e->geo.hi[2]);
  }
  for (int a = 0; a < 3; ++a) {
    double x = origin[a] + t * unit[a];
    point[a] = x < e->geo.lo[a] ? e->geo.lo[a] : (x > e->geo.hi[a] ? e->geo.hi[a] : x);
  }
  point[hv_face_axis(*face)] = hv_face_plane(&e->geo, *face); /* exactly on the face */
  return HETINV_SUCCESS;
}

/* Allocates the beam arrays of an ideal or combination emitter. */
static hetinv_result_t alloc_beams(hetinv_emitter_t *e, int32_t count) {
  e->count = count;
  e->points = hv_calloc(e->ctx, (size_t)count * 3, sizeof(double));
  e->directions = hv_calloc(e->ctx, (size_t)count * 3, sizeof(double));
  e->faces = hv_calloc(e->ctx, (size_t)count, sizeof(hetinv_face_t));
  e->cdf = hv_calloc(e->ctx, (size_t)count, sizeof(double));
  if (!e->points || !e->directions || !e->faces || !e->cdf) {
    return HV_FAIL(e->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %d sources", (int)count);
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_emitter_create_ideal(const hetinv_medium_t *medium,
                                                       const double origin[3],
                                                       const double direction[3],
                                                       hetinv_emitter_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  HV_CHECK_NULL(medium->ctx, origin);
  HV_CHECK_NULL(medium->ctx, direction);
  hetinv_emitter_t *e = NULL; /* destroyed on every error path, so never uninitialised */
  hetinv_result_t r = new_emitter(medium, HV_EMITTER_IDEAL, &e);
  if (r == HETINV_SUCCESS) r = alloc_beams(e, 1);
  if (r == HETINV_SUCCESS) r = place_beam(e, -1, origin, direction, e->points, e->faces, e->directions);
  if (r != HETINV_SUCCESS) {
    hetinv_emitter_destroy(&e);
    return r;
  }
  e->cdf[0] = 1.0;
  *out = e;
  return HETINV_SUCCESS;
}

/* Normalises @p w (n weights ≥ 0, not all 0) into a cumulative distribution. */
static hetinv_result_t build_cdf(hetinv_emitter_t *e, const char *what,
                                 const double *w, int32_t n, double *total) {
  double sum = 0.0;
  for (int32_t i = 0; i < n; ++i) {
    if (!isfinite(w[i]) || w[i] < 0.0) {
      return HV_FAIL(e->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "%s[%d] is %g; it must be finite and >= 0", what, (int)i, w[i]);
    }
    sum += w[i];
    e->cdf[i] = sum;
  }
  if (!(sum > 0.0) || !isfinite(sum)) {
    return HV_FAIL(e->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the %d values of %s sum to %g; they must have a finite positive sum", (int)n,
                   what, sum);
  }
  for (int32_t i = 0; i < n; ++i) e->cdf[i] /= sum;
  e->cdf[n - 1] = 1.0;
  *total = sum;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_emitter_create_combination(const hetinv_medium_t *medium,
                                                             int32_t count, const double *origins,
                                                             const double *directions,
                                                             const double *weights,
                                                             hetinv_emitter_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  HV_CHECK_NULL(medium->ctx, origins);
  HV_CHECK_NULL(medium->ctx, directions);
  HV_CHECK_NULL(medium->ctx, weights);
  if (count <= 0) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT, "count is %d; it must be > 0", (int)count);
  }
  if (count > HETINV_MAX_COMBINATION_SOURCES) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "count is %d; at most HETINV_MAX_COMBINATION_SOURCES (%ld)", (int)count,
                   (long)HETINV_MAX_COMBINATION_SOURCES);
  }
  hetinv_emitter_t *e = NULL; /* destroyed on every error path, so never uninitialised */
  hetinv_result_t r = new_emitter(medium, HV_EMITTER_COMBINATION, &e);
  if (r == HETINV_SUCCESS) r = alloc_beams(e, count);
  for (int32_t i = 0; r == HETINV_SUCCESS && i < count; ++i) {
    r = place_beam(e, i, origins + 3 * i, directions + 3 * i, e->points + 3 * i,
                   e->faces + i, e->directions + 3 * i);
  }
  if (r == HETINV_SUCCESS) r = build_cdf(e, "weights", weights, count, &e->power);
  if (r != HETINV_SUCCESS) {
    hetinv_emitter_destroy(&e);
    return r;
  }
  *out = e;
  return HETINV_SUCCESS;
}

/* Checks that a face rectangle [lo, hi] (or a point, lo == hi allowed when
 * @p point) lies on face f of the box. */
static hetinv_result_t check_on_face(const hetinv_emitter_t *e, hetinv_face_t f,
                                     const double lo[2], const double hi[2], bool point) {
  int ax[2];
  hv_face_uv_axes(f, &ax[0], &ax[1]);
  for (int i = 0; i < 2; ++i) {
    double a = e->geo.lo[ax[i]], b = e->geo.hi[ax[i]];
    bool ok = isfinite(lo[i]) && isfinite(hi[i]) && lo[i] >= a && hi[i] <= b &&
              (point ? lo[i] <= hi[i] : lo[i] < hi[i]);
    if (!ok) {
      return HV_FAIL(e->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "%s coordinate %c is [%g, %g]; it must lie within the face's [%g, %g]%s",
                     point ? "point" : "rectangle", "xyz"[ax[i]], lo[i], hi[i], a, b,
                     point ? "" : " with min < max");
    }
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_emitter_create_area(
    const hetinv_medium_t *medium, hetinv_face_t face, const double direction[3],
    const double rect_min[2], const double rect_max[2], int32_t pattern_width,
    int32_t pattern_height, const double *pattern, hetinv_emitter_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  hetinv_context_t *ctx = medium->ctx;
  HV_CHECK_NULL(ctx, direction);
  HV_CHECK_NULL(ctx, rect_min);
  HV_CHECK_NULL(ctx, rect_max);
  hetinv_result_t r = hv_check_face(ctx, face);
  if (r != HETINV_SUCCESS) return r;
  if (pattern_width <= 0 || pattern_height <= 0 ||
      (int64_t)pattern_width * pattern_height > HETINV_MAX_PATTERN_CELLS) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the pattern is %d x %d; each size must be > 0 and the product at most "
                   "HETINV_MAX_PATTERN_CELLS (%ld)",
                   (int)pattern_width, (int)pattern_height, (long)HETINV_MAX_PATTERN_CELLS);
  }
  hetinv_emitter_t *e = NULL; /* destroyed on every error path, so never uninitialised */
  r = new_emitter(medium, HV_EMITTER_AREA, &e);
  if (r != HETINV_SUCCESS) return r;
  e->face = face;
  e->pattern_width = pattern_width;
  e->pattern_height = pattern_height;
  e->count = pattern_width * pattern_height;
  memcpy(e->rect_min, rect_min, sizeof e->rect_min);
  memcpy(e->rect_max, rect_max, sizeof e->rect_max);
  r = hv_normalize3(ctx, "direction", direction, e->direction);
  if (r == HETINV_SUCCESS && e->direction[hv_face_axis(face)] * hv_face_sign(face) >= 0.0) {
    r = HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                "direction (%g, %g, %g) does not point into face %d", direction[0], direction[1],
                direction[2], (int)face);
  }
  if (r == HETINV_SUCCESS) r = check_on_face(e, face, rect_min, rect_max, false);
  if (r == HETINV_SUCCESS) {
    e->cdf = hv_calloc(ctx, (size_t)e->count, sizeof(double));
    if (e->cdf == NULL) r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the pattern");
  }
  if (r == HETINV_SUCCESS) {
    if (pattern != NULL) {
      double total;
      r = build_cdf(e, "pattern", pattern, e->count, &total);
    } else {
      for (int32_t i = 0; i < e->count; ++i) e->cdf[i] = (double)(i + 1) / e->count;
    }
  }
  if (r != HETINV_SUCCESS) {
    hetinv_emitter_destroy(&e);
    return r;
  }
  *out = e;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_emitter_create_diffuse(const hetinv_medium_t *medium,
                                                         hetinv_face_t face,
                                                         const double point[2],
                                                         hetinv_emitter_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  HV_CHECK_NULL(medium->ctx, point);
  hetinv_result_t r = hv_check_face(medium->ctx, face);
  if (r != HETINV_SUCCESS) return r;
  hetinv_emitter_t *e = NULL; /* destroyed on every error path, so never uninitialised */
  r = new_emitter(medium, HV_EMITTER_DIFFUSE, &e);
  if (r != HETINV_SUCCESS) return r;
  e->face = face;
  memcpy(e->rect_min, point, sizeof e->rect_min);
  memcpy(e->rect_max, point, sizeof e->rect_max);
  r = check_on_face(e, face, point, point, true);
  if (r != HETINV_SUCCESS) {
    hetinv_emitter_destroy(&e);
    return r;
  }
  *out = e;
  return HETINV_SUCCESS;
}

/* Smallest i with u < cdf[i] (cdf increasing, cdf[n-1] = 1). */
static int32_t pick(const double *cdf, int32_t n, double u) {
  int32_t lo = 0, hi = n - 1;
  while (lo < hi) {
    int32_t mid = lo + (hi - lo) / 2;
    if (u < cdf[mid]) hi = mid; else lo = mid + 1;
  }
  return lo;
}

/* Point at face coordinates (u, v) of face f. */
static void face_point(const hv_geometry_t *g, hetinv_face_t f, double u, double v, double p[3]) {
  int au, av;
  hv_face_uv_axes(f, &au, &av);
  p[hv_face_axis(f)] = hv_face_plane(g, f);
  p[au] = u;
  p[av] = v;
}

void hv_emitter_sample(const hetinv_emitter_t *e, hv_rng_t *rng, hv_launch_t *out) {
  out->weight = 1.0;
  switch (e->kind) {
    case HV_EMITTER_IDEAL:
    case HV_EMITTER_COMBINATION: {
      int32_t i = e->count == 1 ? 0 : pick(e->cdf, e->count, hv_rng_uniform(rng));
      memcpy(out->point, e->points + 3 * i, sizeof out->point);
      memcpy(out->direction, e->directions + 3 * i, sizeof out->direction);
      out->face = e->faces[i];
      return;
    }
    case HV_EMITTER_AREA: {
      int32_t cell = e->count == 1 ? 0 : pick(e->cdf, e->count, hv_rng_uniform(rng));
      int32_t cx = cell % e->pattern_width, cy = cell / e->pattern_width;
      double du = (e->rect_max[0] - e->rect_min[0]) / e->pattern_width;
      double dv = (e->rect_max[1] - e->rect_min[1]) / e->pattern_height;
      double u = e->rect_min[0] + (cx + hv_rng_uniform(rng)) * du;
      double v = e->rect_min[1] + (cy + hv_rng_uniform(rng)) * dv;
      face_point(&e->geo, e->face, u, v, out->point);
      memcpy(out->direction, e->direction, sizeof out->direction);
      out->face = e->face;
      return;
    }
    case HV_EMITTER_DIFFUSE: {
      face_point(&e->geo, e->face, e->rect_min[0], e->rect_min[1], out->point);
      /* Cosine-weighted about the inward normal. */
      double n_in[3];
      hv_face_normal(e->face, n_in);
      for (int a = 0; a < 3; ++a) n_in[a] = -n_in[a];
      double cos_theta = sqrt(hv_rng_uniform_open(rng));
      hv_dir_from_cos_phi(n_in, cos_theta, hv_rng_uniform(rng), out->direction);
      out->face = e->face;
      return;
    }
  }
}
