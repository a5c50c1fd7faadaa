/* A smooth smoke plume (like Fig. 5 of Gkioulekas et al. 2016): a swirling
 * column with puffs, modulated by fractal value noise. */
#include <math.h>
#include <stddef.h>

#include "acquire/smooth_noise.h"
#include "acquire/volume_internal.h"
#include "core/alloc.h"
#include "core/context_internal.h"
#include "core/error.h"
#include "core/rng.h"
#include "hetinv/acquire.h"
#include "medium/medium_internal.h"

#define HV_SMOKE_SPEC_V1_SIZE (offsetof(hetinv_smoke_spec_t, seed) + sizeof(uint64_t))
#define HV_TWO_PI 6.283185307179586477
#define HV_SMOKE_PUFFS 5
/* Stream index of the plume's shape parameters: beyond every lattice index
 * (< HV_NOISE_LATTICE_LIMIT³ = 2^36) of the noise, which shares the domain. */
#define HV_SMOKE_SHAPE_INDEX (UINT64_C(1) << 40)

HETINV_API void hetinv_smoke_spec_default(hetinv_smoke_spec_t *spec) {
  HV_API_ENTER();
  if (spec == NULL) return;
  *spec = (hetinv_smoke_spec_t){.size = sizeof(hetinv_smoke_spec_t),
                                .lo = {0.01, 0.1, 0.3},
                                .hi = {0.5, 20.0, 0.8},
                                .octaves = 3,
                                .feature_size = 0.25,
                                .seed = 0};
}

static hetinv_result_t check_spec(const hetinv_context_t *ctx, const hetinv_smoke_spec_t *s) {
  if (s->size < HV_SMOKE_SPEC_V1_SIZE) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->size is %zu; it must be at least %zu (use hetinv_smoke_spec_default)",
                   s->size, (size_t)HV_SMOKE_SPEC_V1_SIZE);
  }
  hetinv_result_t r = hv_volume_check_ranges(ctx, s->lo, s->hi);
  if (r != HETINV_SUCCESS) return r;
  if (s->octaves < 1 || s->octaves > HETINV_SMOKE_OCTAVES_MAX) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->octaves is %d; it must be in [1, %d]", (int)s->octaves,
                   HETINV_SMOKE_OCTAVES_MAX);
  }
  if (!(s->feature_size >= HETINV_SMOKE_FEATURE_MIN && s->feature_size <= 1.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->feature_size is %g; it must be in [%g, 1]", s->feature_size,
                   HETINV_SMOKE_FEATURE_MIN);
  }
  return HETINV_SUCCESS;
}

/* The plume's shape, in units of L (the box's largest side), coordinates
 * measured from box_min: a helical axis, a widening column, puffs. */
typedef struct plume {
  double centre[2];   /* the axis' mean (x, z) */
  double swirl;       /* helix radius */
  double turns;       /* helix turns over the height */
  double phase;
  double radius;      /* column radius at the bottom; it grows to 2.5× at the top */
  double height;      /* the box's height / L */
  double puff[HV_SMOKE_PUFFS][4]; /* centre (x, y, z) and radius */
  double puff_weight[HV_SMOKE_PUFFS];
} plume_t;

static void axis_at(const plume_t *p, double t, double *x, double *z) {
  double angle = HV_TWO_PI * p->turns * t + p->phase;
  *x = p->centre[0] + p->swirl * cos(angle);
  *z = p->centre[1] + p->swirl * sin(angle);
}

static plume_t draw_plume(uint64_t seed, const double side[3], double length) {
  hv_rng_t rng = hv_rng_init_domain(seed, HV_RNG_DOMAIN_SMOKE, HV_SMOKE_SHAPE_INDEX, 0);
  plume_t p;
  double width = fmin(side[0], side[2]) / length;
  p.centre[0] = 0.5 * side[0] / length;
  p.centre[1] = 0.5 * side[2] / length;
  p.height = side[1] / length;
  p.swirl = (0.06 + 0.06 * hv_rng_uniform(&rng)) * width;
  p.turns = 0.75 + 0.75 * hv_rng_uniform(&rng);
  p.phase = HV_TWO_PI * hv_rng_uniform(&rng);
  p.radius = (0.05 + 0.03 * hv_rng_uniform(&rng)) * width;
  for (int j = 0; j < HV_SMOKE_PUFFS; ++j) {
    double t = ((double)j + 0.25 + 0.5 * hv_rng_uniform(&rng)) / HV_SMOKE_PUFFS;
    axis_at(&p, t, &p.puff[j][0], &p.puff[j][2]);
    double r = p.radius * (1.0 + 1.5 * t) * (1.0 + 0.4 * hv_rng_uniform(&rng));
    p.puff[j][0] += r * (hv_rng_uniform(&rng) - 0.5);
    p.puff[j][2] += r * (hv_rng_uniform(&rng) - 0.5);
    p.puff[j][1] = t * p.height;
    p.puff[j][3] = r;
    p.puff_weight[j] = 0.5 + 0.5 * hv_rng_uniform(&rng);
  }
  return p;
}

/* The plume's density before noise, at q (units of L, from box_min). */
static double plume_density(const plume_t *p, const double q[3]) {
  double t = q[1] / p->height, ax, az;
  axis_at(p, t, &ax, &az);
  double r = p->radius * (1.0 + 1.5 * t);
  double rho2 = (q[0] - ax) * (q[0] - ax) + (q[2] - az) * (q[2] - az);
  double d = 0.6 * (1.0 - 0.5 * t) * exp(-rho2 / (2.0 * r * r));
  for (int j = 0; j < HV_SMOKE_PUFFS; ++j) {
    double dx = q[0] - p->puff[j][0], dy = q[1] - p->puff[j][1], dz = q[2] - p->puff[j][2];
    d += p->puff_weight[j] *
         exp(-(dx * dx + dy * dy + dz * dz) / (2.0 * p->puff[j][3] * p->puff[j][3]));
  }
  return d;
}

/* Raw density (into sigma_s), σa's modulation and g's field at each voxel;
 * returns the largest raw density. */
static double evaluate(const hetinv_medium_t *m, const plume_t *plume,
                       const hv_smooth_noise_t *noise, double length, double *density,
                       double *absorb, double *aniso) {
  const int32_t nx = m->dims[0], ny = m->dims[1], nz = m->dims[2];
  double highest = 0.0;
#pragma omp parallel for num_threads(m->ctx->thread_count) schedule(static) \
    reduction(max : highest)
  for (int32_t iz = 0; iz < nz; ++iz) {
    for (int32_t iy = 0; iy < ny; ++iy) {
      for (int32_t ix = 0; ix < nx; ++ix) {
        const int32_t idx[3] = {ix, iy, iz};
        double q[3], n[HV_NOISE_CHANNELS];
        for (int a = 0; a < 3; ++a) {
          q[a] = (hv_voxel_centre(m->box_min[a], m->box_max[a], m->dims[a], idx[a]) -
                  m->box_min[a]) / length;
        }
        hv_smooth_noise_eval(noise, q, n);
        size_t i = (size_t)ix + (size_t)nx * ((size_t)iy + (size_t)ny * (size_t)iz);
        density[i] = plume_density(plume, q) * (0.3 + 0.7 * n[0]);
        absorb[i] = 0.75 + 0.25 * n[1];
        aniso[i] = n[2];
        highest = fmax(highest, density[i]);
      }
    }
  }
  return highest;
}

HETINV_API hetinv_result_t hetinv_volume_smoke(hetinv_medium_t *medium,
                                               const hetinv_smoke_spec_t *spec) {
  HV_API_ENTER();
  hetinv_result_t r = hv_volume_check_medium(medium);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = medium->ctx;
  HV_CHECK_NULL(ctx, spec);
  r = check_spec(ctx, spec);
  if (r != HETINV_SUCCESS) return r;
  double side[3], length = 0.0;
  for (int a = 0; a < 3; ++a) {
    side[a] = medium->box_max[a] - medium->box_min[a];
    length = fmax(length, side[a]);
  }
  const plume_t plume = draw_plume(spec->seed, side, length);
  /* Coordinates in units of L from box_min: the lattice starts at 0. With
   * feature_size >= 0.02 and at most 6 octaves it has <= 1602 cells per axis. */
  const hv_smooth_noise_t noise = {.seed = spec->seed,
                                   .domain = HV_RNG_DOMAIN_SMOKE,
                                   .stream_base = 1,
                                   .octaves = spec->octaves,
                                   .origin = {0.0, 0.0, 0.0},
                                   .spacing = spec->feature_size};
  double *values[HETINV_PARAM_COUNT] = {NULL, NULL, NULL};
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    values[p] = hv_calloc(ctx, medium->voxel_count, sizeof(double));
    if (values[p] == NULL) {
      for (int q = 0; q < p; ++q) hv_free(ctx, values[q]);
      return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu voxels",
                     medium->voxel_count);
    }
  }
  double *sa = values[HETINV_PARAM_SIGMA_A], *ss = values[HETINV_PARAM_SIGMA_S],
         *g = values[HETINV_PARAM_G];
  double highest = evaluate(medium, &plume, &noise, length, ss, sa, g);
  const double *lo = spec->lo, *hi = spec->hi;
  for (size_t i = 0; i < medium->voxel_count; ++i) {
    double d = highest > 0.0 ? ss[i] / highest : 0.0; /* in [0, 1], 1 at the densest voxel */
    sa[i] = hv_volume_lerp(lo[HETINV_PARAM_SIGMA_A], hi[HETINV_PARAM_SIGMA_A], d * sa[i]);
    ss[i] = hv_volume_lerp(lo[HETINV_PARAM_SIGMA_S], hi[HETINV_PARAM_SIGMA_S], d);
    g[i] = hv_volume_lerp(lo[HETINV_PARAM_G], hi[HETINV_PARAM_G], g[i]);
  }
  r = hv_volume_store(medium, values);
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) hv_free(ctx, values[p]);
  return r;
}
