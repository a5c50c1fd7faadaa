#include "acquire/poisson.h"

#include <assert.h>
#include <math.h>

/* log(√(2π)) */
#define HV_LOG_SQRT_2PI 0.91893853320467274178

/* Stirling's correction log(k!) − [(k + ½) log k − k + log √(2π)] for k >= 16:
 * the series 1/(12k) − 1/(360k³) + 1/(1260k⁵) − 1/(1680k⁷), whose next term
 * is below 1e-15 · (1/k)^9. */
static double stirling_correction(double k) {
  double r = 1.0 / k, r2 = r * r;
  return r * (1.0 / 12 - r2 * (1.0 / 360 - r2 * (1.0 / 1260 - r2 * (1.0 / 1680))));
}

double hv_log_factorial(double k) {
  if (k < 16.0) {
    double f = 1.0; /* exact: 15! < 2^53 */
    for (double i = 2.0; i <= k; i += 1.0) f *= i;
    return log(f);
  }
  return (k + 0.5) * log(k) - k + HV_LOG_SQRT_2PI + stirling_correction(k);
}

/* log P(K = k) for K ~ Poisson(λ). For large k the terms −λ + k log λ and
 * log k! are huge and nearly cancel; written around d = k − λ instead,
 *   log P = d − k·log1p(d/λ) − ½ log(2πk) − correction(k),
 * whose only cancellation is between d and k·log1p(d/λ), both O(√λ). */
static double log_pmf(double k, double lambda) {
  if (k < 16.0) return -lambda + k * log(lambda) - hv_log_factorial(k);
  double d = k - lambda;
  return d - k * log1p(d / lambda) - 0.5 * log(k) - HV_LOG_SQRT_2PI - stirling_correction(k);
}

/* Knuth: the number of uniforms whose running product stays above e^−λ. */
static double poisson_multiplication(double lambda, hv_rng_t *rng) {
  double limit = exp(-lambda), product = hv_rng_uniform_open(rng), k = 0.0;
  while (product > limit) {
    k += 1.0;
    product *= hv_rng_uniform_open(rng);
  }
  return k;
}

/* PTRS, Hörmann (1993), Algorithm PTRS with the constants of its Table 1. */
static double poisson_ptrs(double lambda, hv_rng_t *rng) {
  double slam = sqrt(lambda);
  double b = 0.931 + 2.53 * slam;
  double a = -0.059 + 0.02483 * b;
  double log_inv_alpha = log(1.1239 + 1.1328 / (b - 3.4));
  double v_r = 0.9277 - 3.6224 / (b - 2.0);
  for (;;) {
    double u = hv_rng_uniform_open(rng) - 0.5; /* open: us > 0 below */
    double v = hv_rng_uniform_open(rng);
    double us = 0.5 - fabs(u);
    double k = floor((2.0 * a / us + b) * u + lambda + 0.43);
    if (us >= 0.07 && v <= v_r) return k; /* the squeeze: ~89 % of draws */
    if (k < 0.0 || (us < 0.013 && v > us)) continue;
    if (log(v) + log_inv_alpha - log(a / (us * us) + b) <= log_pmf(k, lambda)) return k;
  }
}

double hv_poisson_sample(double lambda, hv_rng_t *rng) {
  assert(lambda >= 0.0 && lambda <= HV_POISSON_LAMBDA_MAX);
  if (lambda == 0.0) return 0.0;
  if (lambda < HV_POISSON_PTRS_MIN) return poisson_multiplication(lambda, rng);
  return poisson_ptrs(lambda, rng);
}
