/* The unknown calibration gain of hetinv_estimator_loss_gradient(): the
 * model k·I is fitted to the measured values in closed form at each call
 * (hetinv/estimator.h says why the model, not the data, is scaled, and what
 * the fit does to the gradient's bias).
 *
 * The denominator Σ w·E[I]² is estimated without bias: a rendered I² is
 * E[I]² plus the render's variance, so Σ w·I² made the gain low by about
 * the renders' relative variance (−37 % at 100 photons per emitter in the
 * files round trip, docs/results/gain.md); I² − s², s the batch-means
 * standard error of the same render, is the U-statistic Σ_{b≠c} m_b·m_c /
 * (B(B − 1)) of the batch means m_b, unbiased for E[I]² when the batches
 * are independent and of equal size (photons a multiple of batches). */
#include "estimator/gain.h"

#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "estimator/estimator_internal.h"
#include "estimator/loss_term.h"
#include "sampling/measurements_internal.h"

HETINV_API hetinv_result_t hetinv_estimator_set_gain_mode(hetinv_estimator_t *estimator,
                                                          hetinv_gain_mode_t mode) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, estimator);
  if (mode != HETINV_GAIN_NONE && mode != HETINV_GAIN_GLOBAL && mode != HETINV_GAIN_PER_EMITTER) {
    return HV_FAIL(estimator->ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "mode is %d; it must be HETINV_GAIN_NONE (0), HETINV_GAIN_GLOBAL (1) or "
                   "HETINV_GAIN_PER_EMITTER (2)", (int)mode);
  }
  estimator->gain_mode = mode;
  estimator->gain_count = 0;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_estimator_get_gain_mode(const hetinv_estimator_t *estimator,
                                                          hetinv_gain_mode_t *mode) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, estimator);
  HV_CHECK_NULL(estimator->ctx, mode);
  *mode = estimator->gain_mode;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_estimator_get_gains(const hetinv_estimator_t *estimator,
                                                      double *gains, size_t capacity,
                                                      size_t *count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, estimator);
  const hetinv_context_t *ctx = estimator->ctx;
  if (estimator->gain_mode == HETINV_GAIN_NONE) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE,
                   "the gain mode is HETINV_GAIN_NONE: no gain is fitted "
                   "(hetinv_estimator_set_gain_mode)");
  }
  if (estimator->gain_count == 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE,
                   "no loss gradient has succeeded since the gain mode was set");
  }
  if (count) *count = estimator->gain_count;
  if (capacity == 0) return HETINV_SUCCESS;
  HV_CHECK_NULL(ctx, gains);
  if (capacity < estimator->gain_count) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "capacity is %zu; the last call fitted %zu gains",
                   capacity, estimator->gain_count);
  }
  memcpy(gains, estimator->gains, estimator->gain_count * sizeof(double));
  return HETINV_SUCCESS;
}

/* The least-squares gain Σ m·w·I·Ī / Σ m·w·E[I]² from the sums num, den
 * (E[I]² estimated without bias) and den_plain (Σ m·w·I², the fallback when
 * den is not positive: so few photons that the estimate is noise). */
static double fitted(double num, double den, double den_plain) {
  if (!(den > 0.0)) den = den_plain;
  if (!(den > 0.0)) return 0.0; /* no used value renders light: nothing to scale */
  double k = num / den;
  return k > 0.0 ? k : 0.0;
}

/* The sums of value range [lo, hi): num, den (I² less its variance, the
 * squared standard error, when given) and den_plain. */
static void add_sums(const hetinv_measurements_t *set, const double *values, const double *std_errors, size_t lo,
                     size_t hi, double sums[3]) {
  for (size_t i = lo; i < hi; ++i) {
    if (!set->mask[i]) continue;
    double w = set->weights[i], sq = values[i] * values[i];
    double var = std_errors ? std_errors[i] * std_errors[i] : 0.0;
    sums[0] += w * values[i] * set->values[i];
    sums[1] += w * (sq - var);
    sums[2] += w * sq;
  }
}

hetinv_result_t hv_gain_fit(hetinv_estimator_t *est, const hv_pass_t *pass,
                            const hetinv_measurements_t *set, const double *values,
                            const double *std_errors, double *cot, double *loss) {
  const hv_plans_t *plans = &pass->plans;
  bool global = est->gain_mode == HETINV_GAIN_GLOBAL;
  size_t count = global ? 1 : (size_t)plans->count;
  if (count > est->gain_capacity) {
    double *grown = hv_calloc(pass->ctx, count, sizeof(double));
    if (grown == NULL) {
      return HV_FAIL(pass->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu gains", count);
    }
    hv_free(pass->ctx, est->gains);
    est->gains = grown;
    est->gain_capacity = count;
  }
  /* Each value belongs to the rows of exactly one plan (emitter); sums run
   * over plans in order, then their ranges, so they do not depend on the
   * thread or rank count. */
  double sums[3] = {0.0, 0.0, 0.0};
  for (int32_t e = 0; e < plans->count; ++e) {
    const hv_plan_t *plan = &plans->plan[e];
    if (!global) sums[0] = sums[1] = sums[2] = 0.0;
    for (int32_t i = 0; i < plan->range_count; ++i) {
      add_sums(set, values, std_errors, plan->range_lo[i], plan->range_hi[i], sums);
    }
    if (!global) est->gains[e] = fitted(sums[0], sums[1], sums[2]);
  }
  if (global) est->gains[0] = fitted(sums[0], sums[1], sums[2]);
  /* k* minimises L(k, π), so by the envelope theorem the gradient of
   * L(k*(π), π) is ∂L/∂π at k = k*: the cotangent 2·m·w·k·(k·I − Ī), with
   * no term through the dependence of k* on π. */
  const double clip = est->param[HETINV_ESTIMATOR_LOSS_CLIP];
  double sum = 0.0;
  for (int32_t e = 0; e < plans->count; ++e) {
    const hv_plan_t *plan = &plans->plan[e];
    double k = est->gains[global ? 0 : e];
    for (int32_t i = 0; i < plan->range_count; ++i) {
      for (size_t n = plan->range_lo[i]; n < plan->range_hi[i]; ++n) {
        double w = set->mask[n] ? set->weights[n] : 0.0, slope;
        sum += hv_loss_term(w, k * values[n] - set->values[n], clip, set->clip_below[n], set->clip_above[n], &slope);
        cot[n] = k * slope;
      }
    }
  }
  *loss = sum;
  est->gain_count = count;
  return HETINV_SUCCESS;
}
