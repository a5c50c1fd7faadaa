#include <math.h>
#include <stdlib.h>

#include "core/alloc.h"
#include "core/error.h"
#include "sampling/pathlength_internal.h"

/* Gaussian windows are cut where exp(-z²/2) < 1.3e-14 of their peak. */
#define HV_GAUSSIAN_REACH_SIGMAS 8.0

HETINV_API void hetinv_pathlength_destroy(hetinv_pathlength_t **pathlength) {
  HV_API_ENTER();
  if (pathlength == NULL || *pathlength == NULL) return;
  hetinv_pathlength_t *p = *pathlength;
  hv_free(p->ctx, p->sorted);
  hv_free(p->ctx, p->bin_of);
  hv_free(p->ctx, p->tap_offset);
  hv_free(p->ctx, p->tap_weight);
  hv_free(p->ctx, p);
  *pathlength = NULL;
}

HETINV_API hetinv_result_t hetinv_pathlength_create_steady(hetinv_context_t *ctx,
                                                           hetinv_pathlength_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  hetinv_pathlength_t *p = hv_calloc(ctx, 1, sizeof *p);
  if (p == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate");
  p->ctx = ctx;
  p->steady = true;
  p->count = 1;
  *out = p;
  return HETINV_SUCCESS;
}

/* Insertion sort of (centre, bin) pairs: bin lists are short and often sorted already. */
static void sort_centres(double *c, int32_t *bin, int32_t n) {
  for (int32_t i = 1; i < n; ++i) {
    double x = c[i];
    int32_t b = bin[i], j = i - 1;
    while (j >= 0 && c[j] > x) {
      c[j + 1] = c[j];
      bin[j + 1] = bin[j];
      --j;
    }
    c[j + 1] = x;
    bin[j + 1] = b;
  }
}

HETINV_API hetinv_result_t hetinv_pathlength_create_bins(hetinv_context_t *ctx,
                                                         hetinv_window_t window, int32_t count,
                                                         const double *centres, double width,
                                                         hetinv_pathlength_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, centres);
  if (window != HETINV_WINDOW_BOX && window != HETINV_WINDOW_GAUSSIAN) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "window is %d; it must be HETINV_WINDOW_BOX (0) or HETINV_WINDOW_GAUSSIAN (1)",
                   (int)window);
  }
  if (count <= 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "count is %d; it must be > 0", (int)count);
  }
  if (count > HETINV_MAX_PATHLENGTH_BINS) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "count is %d; at most HETINV_MAX_PATHLENGTH_BINS (%d)", (int)count,
                   HETINV_MAX_PATHLENGTH_BINS);
  }
  if (!isfinite(width) || !(width > 0.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "width is %g; it must be finite and > 0", width);
  }
  for (int32_t i = 0; i < count; ++i) {
    if (!isfinite(centres[i]) || centres[i] < 0.0) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "centres[%d] is %g; it must be finite and >= 0", (int)i, centres[i]);
    }
  }
  hetinv_pathlength_t *p = hv_calloc(ctx, 1, sizeof *p);
  if (p != NULL) {
    p->ctx = ctx;
    p->sorted = hv_calloc(ctx, (size_t)count, sizeof(double));
    p->bin_of = hv_calloc(ctx, (size_t)count, sizeof(int32_t));
  }
  if (p == NULL || p->sorted == NULL || p->bin_of == NULL) {
    hetinv_pathlength_destroy(&p);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %d bins", (int)count);
  }
  p->window = window;
  p->count = count;
  p->width = width;
  p->reach = window == HETINV_WINDOW_BOX ? 0.5 * width : HV_GAUSSIAN_REACH_SIGMAS * width;
  for (int32_t i = 0; i < count; ++i) {
    p->sorted[i] = centres[i];
    p->bin_of[i] = i;
  }
  sort_centres(p->sorted, p->bin_of, count);
  *out = p;
  return HETINV_SUCCESS;
}

HETINV_API int32_t hetinv_pathlength_bin_count(const hetinv_pathlength_t *pathlength) {
  HV_API_ENTER();
  return pathlength ? pathlength->count : 0;
}
