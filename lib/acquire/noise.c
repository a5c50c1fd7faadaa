/* The affine sensor noise model (Hasinoff, Durand & Freeman 2010): Poisson
 * photon counts, Gaussian read noise, saturation at the full well. */
#include <math.h>
#include <stddef.h>

#include "acquire/poisson.h"
#include "core/context_internal.h"
#include "core/error.h"
#include "core/rng.h"
#include "hetinv/acquire.h"

/* Members every caller's struct must have (the first version). */
#define HV_NOISE_MODEL_V1_SIZE (offsetof(hetinv_noise_model_t, first_index) + sizeof(uint64_t))

/* Streams of value i (index = first_index + i): the Poisson count draws from
 * stream 0, the read noise from stream 1, so that the counts do not depend
 * on read_noise. */
enum { HV_NOISE_STREAM_PHOTONS = 0, HV_NOISE_STREAM_READ = 1 };

/* Parallelise only when there is enough work to pay for the threads. */
#define HV_NOISE_PARALLEL_MIN 4096

HETINV_API void hetinv_noise_model_default(hetinv_noise_model_t *model) {
  HV_API_ENTER();
  if (model == NULL) return;
  *model = (hetinv_noise_model_t){.size = sizeof(hetinv_noise_model_t),
                                  .full_well = 20000.0,
                                  .read_noise = 5.0,
                                  .exposure = 0.0,
                                  .auto_level = 0.9,
                                  .seed = 0,
                                  .first_index = 0};
}

static hetinv_result_t check_model(const hetinv_context_t *ctx, const hetinv_noise_model_t *m) {
  if (m->size < HV_NOISE_MODEL_V1_SIZE) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "model->size is %zu; it must be at least %zu (use hetinv_noise_model_default)",
                   m->size, (size_t)HV_NOISE_MODEL_V1_SIZE);
  }
  if (!(isfinite(m->full_well) && m->full_well > 0.0 &&
        m->full_well <= HETINV_NOISE_FULL_WELL_MAX)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "model->full_well is %g; it must be finite, > 0 and <= %g electrons",
                   m->full_well, HETINV_NOISE_FULL_WELL_MAX);
  }
  if (!(isfinite(m->read_noise) && m->read_noise >= 0.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "model->read_noise is %g; it must be finite and >= 0 electrons",
                   m->read_noise);
  }
  if (!(isfinite(m->exposure) && m->exposure >= 0.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "model->exposure is %g; it must be finite and > 0, or 0 for automatic exposure",
                   m->exposure);
  }
  if (!(m->auto_level > 0.0 && m->auto_level <= 1.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "model->auto_level is %g; it must be in (0, 1]", m->auto_level);
  }
  return HETINV_SUCCESS;
}

/* A standard normal variate (Box–Muller, the cosine branch). */
static double normal_sample(hv_rng_t *rng) {
  double r = sqrt(-2.0 * log(hv_rng_uniform_open(rng)));
  return r * cos(6.283185307179586477 * hv_rng_uniform(rng));
}

/* Recorded electrons of one value with mean lambda electrons. */
static double electrons(double lambda, const hetinv_noise_model_t *m, uint64_t index) {
  if (!(lambda <= HV_POISSON_LAMBDA_MAX)) return m->full_well; /* saturates: see the header */
  hv_rng_t photons = hv_rng_init_domain(m->seed, HV_RNG_DOMAIN_NOISE, index,
                                        HV_NOISE_STREAM_PHOTONS);
  double e = hv_poisson_sample(lambda, &photons);
  if (m->read_noise > 0.0) {
    hv_rng_t read = hv_rng_init_domain(m->seed, HV_RNG_DOMAIN_NOISE, index, HV_NOISE_STREAM_READ);
    e += m->read_noise * normal_sample(&read);
  }
  return fmin(e, m->full_well); /* negative counts are kept: unbiased */
}

HETINV_API hetinv_result_t hetinv_noise_apply(hetinv_context_t *ctx,
                                              const hetinv_noise_model_t *model,
                                              const double *clean, double *noisy,
                                              double *std_errors, size_t count,
                                              double *exposure_used) {
  HV_API_ENTER();
  if (exposure_used != NULL) *exposure_used = 0.0;
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, model);
  HV_CHECK_NULL(ctx, clean);
  HV_CHECK_NULL(ctx, noisy);
  hetinv_result_t r = check_model(ctx, model);
  if (r != HETINV_SUCCESS) return r;
  if (count == 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "count is 0; there must be a value");
  }
  if (model->first_index > HV_RNG_PHOTON_LIMIT || count > HV_RNG_PHOTON_LIMIT - model->first_index) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "model->first_index + count is %llu + %zu; it must be <= 2^48",
                   (unsigned long long)model->first_index, count);
  }
  double largest = 0.0;
  for (size_t i = 0; i < count; ++i) {
    if (!(isfinite(clean[i]) && clean[i] >= 0.0)) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "clean[%zu] is %g; it must be finite and >= 0", i, clean[i]);
    }
    largest = fmax(largest, clean[i]);
  }
  double exposure = model->exposure;
  if (exposure == 0.0) {
    if (largest == 0.0) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "all %zu clean values are 0; automatic exposure (model->exposure = 0) needs "
                     "one > 0, else set model->exposure",
                     count);
    }
    exposure = model->auto_level * model->full_well / largest;
    if (!(isfinite(exposure) && exposure > 0.0)) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "the largest clean value %g gives the automatic exposure %g; it must be "
                     "finite and > 0, so set model->exposure",
                     largest, exposure);
    }
  }
  const double read_variance = model->read_noise * model->read_noise;
  const ptrdiff_t n = (ptrdiff_t)count;
#pragma omp parallel for num_threads(ctx->thread_count) schedule(static) \
    if (count >= HV_NOISE_PARALLEL_MIN)
  for (ptrdiff_t i = 0; i < n; ++i) {
    double e = electrons(exposure * clean[i], model, model->first_index + (uint64_t)i);
    noisy[i] = e / exposure;
    if (std_errors != NULL) {
      /* hypot where read_noise² overflows (read_noise past 1e154): the
       * standard error itself is finite. */
      std_errors[i] = (isfinite(read_variance) ? sqrt(fmax(e, 0.0) + read_variance)
                                               : hypot(sqrt(fmax(e, 0.0)), model->read_noise)) / exposure;
    }
  }
  if (exposure_used != NULL) *exposure_used = exposure;
  return HETINV_SUCCESS;
}
