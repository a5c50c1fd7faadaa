/* hetinv-clip-scales-check: test helper. Huber's clip counted in the
 * residual's standard errors (estimator.loss_clip_errors "residual") stores
 * per value the clip scale s = √w·sqrt(σ² + σ_R²), σ the data's standard
 * error, σ_R² the optimizer's render's variance and w the weight: the
 * library clips at c·s/√w. Run A uses the variance weighting (w = 1/σ²) and
 * run B, of the same data, the residual weighting (w = 1/(σ² + σ_R²)), so
 * s_A = sqrt(w_A / w_B) (to the files' float rounding) wherever w_A > 0,
 * and every s_A ≥ 1. Both sides are checked ("clip_scale_below" and
 * "clip_scale_above"; run A uses "residual", which scales both).
 *
 *   usage: hetinv-clip-scales-check A/measurements.exr B/measurements.exr
 *
 * Prints the values checked and the mean scale; exit 0 when the relation
 * holds for each, 1 otherwise (naming the first that fails), 2 on usage. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>

#include "check_channel.h"

#define PROG "hetinv-clip-scales-check"

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: hetinv-clip-scales-check A/measurements.exr B/measurements.exr\n");
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return 1;
  hetinv_image_t *a = NULL, *b = NULL;
  int status = 1;
  size_t n = 0, nb = 0, checked = 0;
  const float *below = check_channel(ctx, PROG, argv[1], &a, "clip_scale_below", &n);
  const float *scale = below ? check_channel(ctx, PROG, argv[1], &a, "clip_scale_above", &n) : NULL;
  const float *wa = scale ? check_channel(ctx, PROG, argv[1], &a, "weight", &n) : NULL;
  const float *wb = wa ? check_channel(ctx, PROG, argv[2], &b, "weight", &nb) : NULL;
  if (wb && nb != n) fprintf(stderr, "hetinv-clip-scales-check: %zu values in %s, %zu in %s\n", n, argv[1], nb, argv[2]);
  double sum = 0.0;
  if (wb && nb == n) status = 0;
  for (size_t i = 0; i < n && status == 0; ++i) {
    double s = (double)scale[i], expect = wa[i] > 0.0f && wb[i] > 0.0f ? sqrt((double)wa[i] / (double)wb[i]) : 1.0;
    bool ok = s >= 1.0 && fabs(s - expect) <= 1e-6 * expect && below[i] == scale[i];
    if (!ok) {
      fprintf(stderr, "hetinv-clip-scales-check: value %zu: clip_scale_above %.9g (below %.9g); weights %.9g and %.9g "
                      "give %.9g\n", i, s, (double)below[i], (double)wa[i], (double)wb[i], expect);
      status = 1;
    }
    checked += s > 1.0;
    sum += s;
  }
  if (status == 0) printf("%zu values, %zu of them scaled; mean clip scale %.4g\n", n, checked, sum / (double)n);
  hetinv_image_destroy(&a);
  hetinv_image_destroy(&b);
  hetinv_context_destroy(&ctx);
  return status;
}
