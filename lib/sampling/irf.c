/* Instrument response functions of time-resolved detectors: pathlength
 * bins whose windows are convolved with the IRF's samples
 * (pathlength_internal.h applies the taps as each path is scored), and the
 * conversion of a time axis in picoseconds into pathlengths. */
#include <math.h>

#include "core/alloc.h"
#include "core/error.h"
#include "sampling/pathlength_internal.h"

/* Checks the IRF's samples; on success *kept is the number of non-zero
 * samples and *sum their sum (finite, > 0). */
static hetinv_result_t check_irf(const hetinv_context_t *ctx, int32_t n, const double *offsets,
                                 const double *samples, int32_t *kept, double *sum) {
  if (n <= 0 || n > HETINV_MAX_IRF_SAMPLES) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "irf_count is %d; it must be in [1, HETINV_MAX_IRF_SAMPLES (%d)]", (int)n,
                   HETINV_MAX_IRF_SAMPLES);
  }
  *kept = 0;
  *sum = 0.0;
  for (int32_t j = 0; j < n; ++j) {
    if (!isfinite(offsets[j])) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "irf_offsets[%d] is %g; it must be finite", (int)j, offsets[j]);
    }
    if (!isfinite(samples[j]) || samples[j] < 0.0) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "irf_samples[%d] (offset %g) is %g; it must be finite and >= 0", (int)j,
                     offsets[j], samples[j]);
    }
    *sum += samples[j];
    *kept += samples[j] > 0.0;
  }
  if (!(*sum > 0.0) || !isfinite(*sum)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the %d IRF samples sum to %g; the sum must be finite and > 0", (int)n, *sum);
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_pathlength_create_bins_irf(
    hetinv_context_t *ctx, hetinv_window_t window, int32_t count, const double *centres,
    double width, int32_t irf_count, const double *irf_offsets, const double *irf_samples,
    hetinv_pathlength_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, irf_offsets);
  HV_CHECK_NULL(ctx, irf_samples);
  int32_t kept = 0;
  double sum = 0.0;
  hetinv_result_t r = check_irf(ctx, irf_count, irf_offsets, irf_samples, &kept, &sum);
  hetinv_pathlength_t *p = NULL;
  if (r == HETINV_SUCCESS) r = hetinv_pathlength_create_bins(ctx, window, count, centres, width, &p);
  if (r != HETINV_SUCCESS) return r;
  p->tap_offset = hv_calloc(ctx, (size_t)kept, sizeof(double));
  p->tap_weight = hv_calloc(ctx, (size_t)kept, sizeof(double));
  if (p->tap_offset == NULL || p->tap_weight == NULL) {
    hetinv_pathlength_destroy(&p);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %d IRF samples", (int)kept);
  }
  p->late = -(double)INFINITY;
  for (int32_t j = 0; j < irf_count; ++j) {
    if (!(irf_samples[j] > 0.0)) continue; /* a zero tap adds nothing: skip its bin search */
    p->tap_offset[p->taps] = irf_offsets[j];
    p->tap_weight[p->taps] = irf_samples[j] / sum;
    if (-irf_offsets[j] > p->late) p->late = -irf_offsets[j];
    p->taps++;
  }
  *out = p;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_irf_offsets_from_times(const double *times_ps, size_t count,
                                                         double eta, double length_unit_mm,
                                                         double *pathlengths) {
  HV_API_ENTER();
  if (count == 0) return HETINV_SUCCESS;
  HV_CHECK_NULL(NULL, times_ps);
  HV_CHECK_NULL(NULL, pathlengths);
  if (!isfinite(eta) || !(eta >= 1.0)) {
    return HV_FAIL(NULL, HETINV_ERROR_INVALID_ARGUMENT, "eta is %g; it must be finite and >= 1", eta);
  }
  if (!isfinite(length_unit_mm) || !(length_unit_mm > 0.0)) {
    return HV_FAIL(NULL, HETINV_ERROR_INVALID_ARGUMENT,
                   "length_unit_mm is %g; it must be finite and > 0 (1 for mm, 10 for cm)",
                   length_unit_mm);
  }
  /* mm per ps in the medium, in the medium's unit: one factor, so a time
   * and its negative give opposite pathlengths exactly. */
  double speed = HETINV_SPEED_OF_LIGHT_MM_PER_PS / eta / length_unit_mm;
  for (size_t i = 0; i < count; ++i) {
    if (!isfinite(times_ps[i]) || !isfinite(times_ps[i] * speed)) {
      return HV_FAIL(NULL, HETINV_ERROR_INVALID_ARGUMENT,
                     "times_ps[%zu] is %g; it must be finite (and so must be its pathlength)", i,
                     times_ps[i]);
    }
  }
  for (size_t i = 0; i < count; ++i) pathlengths[i] = times_ps[i] * speed;
  return HETINV_SUCCESS;
}
