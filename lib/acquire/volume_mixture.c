/* Random Gaussian-mixture volumes (Fig. 4 of Gkioulekas et al. 2016). */
#include <math.h>
#include <stddef.h>

#include "acquire/volume_internal.h"
#include "core/alloc.h"
#include "core/context_internal.h"
#include "core/error.h"
#include "core/rng.h"
#include "hetinv/acquire.h"
#include "medium/medium_internal.h"

#define HV_MIXTURE_SPEC_V1_SIZE (offsetof(hetinv_mixture_spec_t, seed) + sizeof(uint64_t))

HETINV_API void hetinv_mixture_spec_default(hetinv_mixture_spec_t *spec) {
  HV_API_ENTER();
  if (spec == NULL) return;
  *spec = (hetinv_mixture_spec_t){.size = sizeof(hetinv_mixture_spec_t),
                                  .lo = {0.05, 1.0, 0.0},
                                  .hi = {0.5, 10.0, 0.9},
                                  .components = 2,
                                  .min_width = 0.15,
                                  .max_width = 0.4,
                                  .constant_axis = -1,
                                  .seed = 0};
}

static hetinv_result_t check_spec(const hetinv_context_t *ctx, const hetinv_mixture_spec_t *s) {
  if (s->size < HV_MIXTURE_SPEC_V1_SIZE) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->size is %zu; it must be at least %zu (use hetinv_mixture_spec_default)",
                   s->size, (size_t)HV_MIXTURE_SPEC_V1_SIZE);
  }
  hetinv_result_t r = hv_volume_check_ranges(ctx, s->lo, s->hi);
  if (r != HETINV_SUCCESS) return r;
  if (s->components < 1 || s->components > HETINV_MIXTURE_COMPONENTS_MAX) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->components is %d; it must be in [1, %d]", (int)s->components,
                   HETINV_MIXTURE_COMPONENTS_MAX);
  }
  if (!(isfinite(s->min_width) && s->min_width > 0.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->min_width is %g; it must be finite and > 0", s->min_width);
  }
  if (!(isfinite(s->max_width) && s->max_width >= s->min_width)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->max_width is %g; it must be finite and >= spec->min_width (%g)",
                   s->max_width, s->min_width);
  }
  if (s->constant_axis < -1 || s->constant_axis > 2) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "spec->constant_axis is %d; it must be -1 (3D), 0, 1 or 2",
                   (int)s->constant_axis);
  }
  return HETINV_SUCCESS;
}

typedef struct gaussian {
  double centre[3];
  double inv_two_var; /* 1 / (2 s²) */
  double weight;
} gaussian_t;

/* Component c of parameter p draws from its own stream: (seed, p·16 + c). */
static gaussian_t draw_gaussian(const hetinv_mixture_spec_t *s, const hetinv_medium_t *m,
                                double side, hetinv_param_t p, int32_t c) {
  hv_rng_t rng = hv_rng_init_domain(s->seed, HV_RNG_DOMAIN_MIXTURE,
                                    (uint64_t)p * HETINV_MIXTURE_COMPONENTS_MAX + (uint64_t)c, 0);
  gaussian_t g;
  for (int a = 0; a < 3; ++a) {
    double u = hv_rng_uniform(&rng);
    g.centre[a] = m->box_min[a] * (1.0 - u) + m->box_max[a] * u;
  }
  double width = (s->min_width + (s->max_width - s->min_width) * hv_rng_uniform(&rng)) * side;
  g.inv_two_var = 1.0 / (2.0 * width * width);
  g.weight = 1.0 - 0.75 * hv_rng_uniform(&rng); /* (0.25, 1] */
  return g;
}

/* Evaluates parameter p's mixture at every voxel centre into out, and maps
 * it onto [lo[p], hi[p]]. */
static void fill_parameter(const hetinv_mixture_spec_t *s, const hetinv_medium_t *m, double side,
                           hetinv_param_t p, double *out) {
  gaussian_t g[HETINV_MIXTURE_COMPONENTS_MAX];
  for (int32_t c = 0; c < s->components; ++c) g[c] = draw_gaussian(s, m, side, p, c);
  const int32_t nx = m->dims[0], ny = m->dims[1], nz = m->dims[2];
  const double use[3] = {s->constant_axis == 0 ? 0.0 : 1.0, s->constant_axis == 1 ? 0.0 : 1.0,
                         s->constant_axis == 2 ? 0.0 : 1.0};
  double lowest = (double)INFINITY, highest = -(double)INFINITY;
#pragma omp parallel for num_threads(m->ctx->thread_count) schedule(static) \
    reduction(min : lowest) reduction(max : highest)
  for (int32_t iz = 0; iz < nz; ++iz) {
    double z = hv_voxel_centre(m->box_min[2], m->box_max[2], nz, iz);
    for (int32_t iy = 0; iy < ny; ++iy) {
      double y = hv_voxel_centre(m->box_min[1], m->box_max[1], ny, iy);
      for (int32_t ix = 0; ix < nx; ++ix) {
        double x = hv_voxel_centre(m->box_min[0], m->box_max[0], nx, ix);
        double v = 0.0;
        for (int32_t c = 0; c < s->components; ++c) {
          double dx = (x - g[c].centre[0]) * use[0], dy = (y - g[c].centre[1]) * use[1],
                 dz = (z - g[c].centre[2]) * use[2];
          v += g[c].weight * exp(-(dx * dx + dy * dy + dz * dz) * g[c].inv_two_var);
        }
        out[(size_t)ix + (size_t)nx * ((size_t)iy + (size_t)ny * (size_t)iz)] = v;
        lowest = fmin(lowest, v);
        highest = fmax(highest, v);
      }
    }
  }
  const double lo = s->lo[p], hi = s->hi[p], span = highest - lowest;
  for (size_t i = 0; i < m->voxel_count; ++i) {
    out[i] = span > 0.0 ? hv_volume_lerp(lo, hi, (out[i] - lowest) / span) : 0.5 * (lo + hi);
  }
}

HETINV_API hetinv_result_t hetinv_volume_gaussian_mixture(hetinv_medium_t *medium,
                                                          const hetinv_mixture_spec_t *spec) {
  HV_API_ENTER();
  hetinv_result_t r = hv_volume_check_medium(medium);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = medium->ctx;
  HV_CHECK_NULL(ctx, spec);
  r = check_spec(ctx, spec);
  if (r != HETINV_SUCCESS) return r;
  /* L: the largest side among the axes the field varies along. */
  double side = 0.0;
  for (int a = 0; a < 3; ++a) {
    if (a != spec->constant_axis) side = fmax(side, medium->box_max[a] - medium->box_min[a]);
  }
  double *values[HETINV_PARAM_COUNT] = {NULL, NULL, NULL};
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    values[p] = hv_calloc(ctx, medium->voxel_count, sizeof(double));
    if (values[p] == NULL) {
      for (int q = 0; q < p; ++q) hv_free(ctx, values[q]);
      return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu voxels",
                     medium->voxel_count);
    }
  }
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    fill_parameter(spec, medium, side, p, values[p]);
  }
  r = hv_volume_store(medium, values);
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) hv_free(ctx, values[p]);
  return r;
}
