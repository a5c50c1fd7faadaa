/* The orthographic sensor: a grid of pixels on a face that sees the light
 * leaving it along one direction, as a telecentric camera does. Radiance
 * along a single direction is a Dirac for light tracing, so it is scored by
 * next-event connections from every scattering vertex (with the specular
 * chains the box's faces make); unscattered light reaches it only if it
 * leaves exactly along that direction, and is reported as ballistic. */
#include <math.h>
#include <string.h>

#include "core/bits.h"
#include "core/compiler.h"
#include "core/error.h"
#include "core/hash.h"
#include "medium/fresnel.h"
#include "medium/medium_internal.h"
#include "sampling/sensor_internal.h"
#include "transport/score.h"
#include "transport/sensor_kind.h"
#include "transport/walk.h"

/* Russian roulette on specular chains. Every reflection multiplies a
 * chain's throughput by the face's Fresnel R (1.7 % at normal incidence
 * for η = 1.3), so after the first few the chain carries almost nothing,
 * yet each bounce is a walk across the box. Once the throughput falls below
 * this fraction of the chain's start, the chain goes on with probability
 * throughput / (ROULETTE · start) at weight ROULETTE · start: unbiased,
 * and the added variance is of the order of R · ROULETTE of the chain's
 * square, far below the vertex's own. A pattern that starts flipped on
 * some axes must reflect at least once on each of them, so the product of
 * those R is known before its first walk and is rouletted the same way.
 * The gradient needs no extra score: the survival probability's score and
 * the weight's cancel (E[1{u < q}/q · f] = f for any q). The old rule, a
 * hard stop at 1e-7 of the start, walked up to ten legs per sensor and
 * vertex: connections were 88 % of the built-in scene's iteration time
 * (docs/results/kernel.md, "Specular chains"). Every hit on a face of the sensor's axis loses
 * at least 1 - R > 0 (no valid sensor direction is totally reflected
 * there), so chains end; total internal reflections at side faces cost
 * nothing (R = 1 keeps the throughput) and may be many in a narrow box. The
 * bounce limit only guards against a pathological R ≈ 1. */
#define ROULETTE 0.1
#define CHAIN_MAX_BOUNCES 1000000

typedef struct ortho {
  double dir_out[3]; /* direction of the light leaving toward the sensor */
  double dir_in[3];  /* ... its direction inside, before refraction */
  /* Radiance per unit of "source strength × transmittance" reaching the
   * face along dir_in: Fresnel transmittance times (η_out/η)², over the
   * projected-area factor |cos| and the pixel area. */
  double connection_scale;
  double ballistic_scale; /* 1 / pixel area */
  /* dir_in is the face's normal: every leg of a chain then keeps the
   * vertex's place on the face (its other coordinates), so the vertex's
   * pixel is known before any walk. */
  bool normal;
  /* The pixels' extent from origin along the face's two axes, shrunk and
   * grown by a relative 1e-12: a vertex offset inside the first is on a
   * pixel, one outside the second on none, whatever the division in
   * hv_sensor_pixel_at rounds to (covers()). */
  double inside[2], outside[2];
  /* The chains' starting patterns: sign flips of dir_in (bit a flips axis
   * a), in increasing order, without those that repeat another's direction
   * (a flip of a zero component). A camera along a face normal has two of
   * eight; testing all eight at every vertex was a third of a
   * reconstruction iteration's mispredicted branches. */
  int32_t pattern_count;
  uint8_t pattern[8];
  double pattern_dir[8][3];
} ortho_t;

/* hv_sensor_pixel_at(s, p) >= 0, exactly, without its two divisions
 * unless p lies within 1e-12 of the pixels' edge: the early test of every
 * connection, where the divisions were 2 % of a reconstruction's
 * iteration (docs/results/kernel.md). */
static inline bool covers(const hetinv_sensor_t *s, const ortho_t *o, const double p[3]) {
  int au, av;
  hv_face_uv_axes(s->face, &au, &av);
  double u = p[au] - s->origin[0], v = p[av] - s->origin[1];
  if (u >= 0.0 && v >= 0.0 && u <= o->inside[0] && v <= o->inside[1]) return true;
  if (u < -1e-12 * s->pixel_size[0] || v < -1e-12 * s->pixel_size[1] || u > o->outside[0] ||
      v > o->outside[1]) {
    return false;
  }
  return hv_sensor_pixel_at(s, p) >= 0;
}

/* Per (emitter, sensor): the Fresnel reflectance of dir_in at the faces of
 * each axis, which every specular chain multiplies by. */
static void prepare(hv_sensor_target_t *t) {
  const hetinv_sensor_t *s = t->sensor;
  const ortho_t *o = s->data;
  double eta = s->geo.eta_out / s->geo.eta, cos_t;
  for (int a = 0; a < 3; ++a) t->cache[a] = hv_fresnel_dielectric(fabs(o->dir_in[a]), eta, &cos_t);
}

/* Next-event connection from scattering vertex r (direction of arrival
 * r->d, weight w after the albedo, the vertex's phase function, pathlength
 * tau so far). The light leaves along the sensor's interior direction ω_i,
 * possibly after specular reflections at other faces (or at the sensor's
 * face itself): each chain starts along a sign flip of ω_i and ends when it
 * reaches the sensor face travelling along ω_i; every chain is followed
 * until its throughput is negligible. */
HV_TARGET_CLONES_X86_64_V3
static void at_vertex(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_sensor_target_t *t,
                      const hv_ray_t *vertex, double w, hv_phase_t phase, double tau, hv_rng_t *rng,
                      hv_tally_t *tally) {
  const hetinv_sensor_t *s = t->sensor;
  const ortho_t *o = s->data;
  const double *d_in = vertex->d, *reflectance = t->cache;
  const hv_grid_t *grid = tr->grid;
  /* A vertex outside the pixels of a camera that looks along the normal
   * cannot reach it by any chain: no walk, no draw. A probe of a few
   * pixels is missed by nearly every vertex. */
  if (o->normal && !covers(s, o, vertex->p)) return;
  hv_grad_tally_t *gt = tally->grad;
  hv_path_log_t *chain = gt ? &gt->chain : NULL;
  bool matched = grid->eta == grid->eta_out; /* no reflections: the direct chain only */
  int32_t patterns = matched ? 1 : o->pattern_count; /* pattern 0 is no flip */
  for (int32_t p = 0; p < patterns; ++p) {
    int flips = o->pattern[p];
    const double *w0 = o->pattern_dir[p];
    double least = 1.0; /* the reflections the pattern cannot avoid */
    for (int a = 0; a < 3; ++a) least *= hv_select(1.0, reflectance[a], (uint32_t)(flips >> a) & 1u);
    /* Survives with probability least / ROULETTE; drawn before the phase
     * function, whose division and square root most such patterns then
     * never pay. */
    double gain = 1.0;
    if (least < ROULETTE) {
      if (hv_rng_uniform(rng) * ROULETTE >= least) continue;
      gain = ROULETTE / least;
    }
    double cos_theta = d_in[0] * w0[0] + d_in[1] * w0[1] + d_in[2] * w0[2];
    double start = w * hv_phase_eval(phase, cos_theta);
    if (!(start > 0.0)) continue;
    double throughput = start * gain;
    if (chain) hv_path_log_reset(chain);
    if (gt && gt->jvp.tangents > 0) {
      hv_jvp_chain_begin(&gt->jvp, hv_vertex_voxel(grid, vertex), hv_phase_dlog_dg(phase, cos_theta));
    }
    hv_ray_t r = *vertex;
    memcpy(r.d, w0, sizeof r.d);
    hv_ray_locate(grid, &r);
    double length = 0.0;
    int state = flips;
    for (int bounce = 0; bounce <= CHAIN_MAX_BOUNCES; ++bounce) {
      double dist;
      hetinv_face_t face;
      double depth = hv_ray_to_boundary(grid, &r, &dist, &face, chain);
      throughput *= exp(-depth);
      length += dist;
      int a = hv_face_axis(face);
      if (state == 0 && face == s->face) {
        int32_t pixel = hv_sensor_pixel_at(s, r.p);
        if (pixel >= 0) {
          hv_score(plan, t, tally, tally->values, chain, pixel, tau + length, throughput * o->connection_scale);
        }
      }
      /* What the face reflects travels on, flipped along its axis. */
      throughput *= reflectance[a];
      if (!(throughput > 0.0)) break; /* index-matched faces reflect nothing: no draw */
      if (throughput < ROULETTE * start) {
        if (!(hv_rng_uniform(rng) * ROULETTE * start < throughput)) break;
        throughput = ROULETTE * start;
      }
      r.d[a] = -r.d[a];
      state ^= 1 << a;
      hv_ray_locate(grid, &r);
    }
    if (chain && chain->cum != 0.0) {
      /* The chain's own segments and the vertex's phase toward w0 score only
       * this chain's splats; its total joins the path's splats. */
      hv_grad_apply_log(gt, grid, chain);
      hv_grad_add(gt, HETINV_PARAM_G, hv_vertex_voxel(grid, vertex), hv_phase_dlog_dg(phase, cos_theta) * chain->cum);
      gt->path.cum += chain->cum;
      gt->path.scored = true;
    }
  }
}

/* Unscattered light is a Dirac in direction: it reaches the sensor only if
 * it leaves exactly along the sensor's direction. It is reported apart
 * from the values, and has no gradient. */
static void at_exit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_sensor_target_t *t,
                    const hv_exit_t *out, hv_tally_t *tally) {
  (void)tr;
  const hetinv_sensor_t *s = t->sensor;
  if (out->scatterings != 0 || tally->ballistic == NULL || s->face != out->face) return;
  const ortho_t *o = s->data;
  double n[3], d[3];
  hv_face_normal(out->face, n);
  hv_refract_cos(out->ray->d, n, out->eta, out->cos_t, d);
  double c = d[0] * o->dir_out[0] + d[1] * o->dir_out[1] + d[2] * o->dir_out[2];
  if (c < 1.0 - 1e-12) return;
  int32_t pixel = hv_sensor_pixel_at(s, out->ray->p);
  hv_path_log_t *log = tally->grad ? &tally->grad->path : NULL;
  if (pixel >= 0) hv_score(plan, t, tally, tally->ballistic, log, pixel, out->tau, out->w * o->ballistic_scale);
}

/* A camera looking along a face normal is reached only from the prism
 * over its pixels: covers()'s outer test, widened by a relative 1e-9 so
 * that no rounding of the box's comparisons skips a vertex it would
 * take. Any other direction reaches it from everywhere. */
static void reach(const hetinv_sensor_t *s, double lo[3], double hi[3]) {
  const ortho_t *o = s->data;
  if (!o->normal) return;
  int ax[2];
  hv_face_uv_axes(s->face, &ax[0], &ax[1]);
  for (int i = 0; i < 2; ++i) {
    double margin = 1e-9 * (fabs(s->origin[i]) + o->outside[i]);
    lo[ax[i]] = s->origin[i] - margin;
    hi[ax[i]] = s->origin[i] + o->outside[i] + margin;
  }
}

/* A camera looking along a face normal connects along that axis, both
 * ways (its chains reflect off the opposite face). */
static uint32_t axis_walks(const hetinv_sensor_t *s) {
  const ortho_t *o = s->data;
  return o->normal ? 3u << (2 * hv_face_axis(s->face)) : 0u;
}

/* The direction it was made for (normalised): the rest of its data follows
 * from it and the grid. */
static uint64_t fingerprint(const hetinv_sensor_t *s, uint64_t h) {
  const ortho_t *o = s->data;
  return hv_fnv1a(h, o->dir_out, sizeof o->dir_out);
}

static const hv_sensor_kind_t ORTHOGRAPHIC = {.name = "orthographic",
                                              .prepare = prepare,
                                              .at_vertex = at_vertex,
                                              .reach = reach,
                                              .at_exit = at_exit,
                                              .axis_walks = axis_walks,
                                              .fingerprint = fingerprint};

/* The interior direction that refracts into dir_out, and the factors of a
 * next-event connection along it. */
static hetinv_result_t set_direction(hetinv_sensor_t *s, ortho_t *o, const double d[3]) {
  hetinv_result_t r = hv_normalize3(s->ctx, "direction", d, o->dir_out);
  if (r != HETINV_SUCCESS) return r;
  double n[3];
  hv_face_normal(s->face, n);
  double cos_out = o->dir_out[hv_face_axis(s->face)] * hv_face_sign(s->face);
  if (!(cos_out > 0.0)) {
    return HV_FAIL(s->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "direction (%g, %g, %g) points %s face %d; it must point away from the medium",
                   d[0], d[1], d[2], cos_out == 0.0 ? "along" : "into the medium through",
                   (int)s->face);
  }
  /* Follow the light backwards: from outside, along -dir_out, into the medium. */
  double back[3] = {-o->dir_out[0], -o->dir_out[1], -o->dir_out[2]}, back_in[3];
  if (!hv_refract(back, n, s->geo.eta / s->geo.eta_out, back_in)) {
    return HV_FAIL(s->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "no light from inside leaves face %d along (%g, %g, %g): with eta %g inside "
                   "and %g outside it lies beyond the critical angle", (int)s->face, d[0], d[1],
                   d[2], s->geo.eta, s->geo.eta_out);
  }
  for (int a = 0; a < 3; ++a) o->dir_in[a] = -back_in[a];
  o->pattern_count = 0;
  for (int flips = 0; flips < 8; ++flips) {
    bool redundant = false;
    for (int a = 0; a < 3; ++a) redundant |= ((flips >> a) & 1) && o->dir_in[a] == 0.0;
    if (redundant) continue;
    int32_t p = o->pattern_count++;
    o->pattern[p] = (uint8_t)flips;
    for (int a = 0; a < 3; ++a) o->pattern_dir[p][a] = ((flips >> a) & 1) ? -o->dir_in[a] : o->dir_in[a];
  }
  int face_axis = hv_face_axis(s->face);
  o->normal = o->dir_in[(face_axis + 1) % 3] == 0.0 && o->dir_in[(face_axis + 2) % 3] == 0.0;
  double cos_in = fabs(o->dir_in[face_axis]), cos_t;
  double eta = s->geo.eta_out / s->geo.eta; /* leaving: η_t / η_i */
  double R = hv_fresnel_dielectric(cos_in, eta, &cos_t);
  double area = s->pixel_size[0] * s->pixel_size[1];
  o->connection_scale = hv_fresnel_radiance_scale(R, eta) / (cos_in * area);
  o->ballistic_scale = 1.0 / area;
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
  /* A value is power per pixel area: an area that underflows to 0 or
   * overflows would make every value inf or 0 with no error. */
  double area = pixel_size[0] * pixel_size[1];
  if (!(isnormal(area) && isnormal(1.0 / area))) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "pixel_size is %g x %g: its area %g is not a normal double with a normal reciprocal "
                   "(about 1e-308 to 1e308); choose a unit in which pixels are nearer 1",
                   pixel_size[0], pixel_size[1], area);
  }
  for (int i = 0; i < 2; ++i) {
    double extent = (i == 0 ? width : height) * pixel_size[i];
    if (!isfinite(origin[i] + extent)) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "origin[%d] + %s x pixel_size[%d] is %g + %d x %g, which is not finite", i,
                     i == 0 ? "width" : "height", i, origin[i], (int)(i == 0 ? width : height), pixel_size[i]);
    }
  }
  hetinv_sensor_t *s = NULL;
  hetinv_result_t r = hv_sensor_new(medium, &ORTHOGRAPHIC, face, sizeof(ortho_t), &s);
  if (r != HETINV_SUCCESS) return r;
  memcpy(s->origin, origin, sizeof s->origin);
  memcpy(s->pixel_size, pixel_size, sizeof s->pixel_size);
  s->width = width;
  s->height = height;
  s->images = true;
  ortho_t *o = s->data;
  for (int i = 0; i < 2; ++i) {
    double extent = (i == 0 ? width : height) * pixel_size[i];
    o->inside[i] = extent * (1.0 - 1e-12);
    o->outside[i] = extent * (1.0 + 1e-12);
  }
  r = set_direction(s, o, direction);
  if (r != HETINV_SUCCESS) {
    hetinv_sensor_destroy(&s);
    return r;
  }
  *out = s;
  return HETINV_SUCCESS;
}
