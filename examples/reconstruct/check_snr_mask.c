/* hetinv-snr-mask-check: test helper. acquisition.min_snr S leaves out of
 * the loss each value v under S standard errors; with min_snr_errors
 * "residual" the error tested is the residual's, sqrt(σ² + σ_R²) (σ the
 * data's, σ_R² the optimizer's render's variance), which is what the
 * residual weighting stores as 1/√w. Run A tests the data's error and
 * run B the residual's, both of the same data under the residual
 * weighting, so per value: B keeps it only if A does; B keeps it exactly
 * when A does and v ≥ S/√w_B (to the files' float rounding). The
 * optimizer rendering fewer photons than the data, B must leave out more.
 *
 *   usage: hetinv-snr-mask-check A/measurements.exr B/measurements.exr S
 *
 * Prints the values each run keeps; exit 0 when the relation holds for
 * each, 1 otherwise (naming the first that fails), 2 on usage. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>

#include "check_channel.h"

#define PROG "hetinv-snr-mask-check"

int main(int argc, char **argv) {
  char *end = NULL;
  double snr = argc == 4 ? strtod(argv[3], &end) : 0.0;
  if (argc != 4 || end == argv[3] || *end != '\0' || !(snr > 0.0)) {
    fprintf(stderr, "usage: " PROG " A/measurements.exr B/measurements.exr S (S > 0)\n");
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return 1;
  hetinv_image_t *a = NULL, *b = NULL;
  size_t n = 0, nb = 0, kept_a = 0, kept_b = 0;
  const float *mask_a = check_channel(ctx, PROG, argv[1], &a, "mask", &n);
  const float *value = mask_a ? check_channel(ctx, PROG, argv[2], &b, "value", &nb) : NULL;
  const float *mask_b = value ? check_channel(ctx, PROG, argv[2], &b, "mask", &nb) : NULL;
  const float *wb = mask_b ? check_channel(ctx, PROG, argv[2], &b, "weight", &nb) : NULL;
  int status = wb && nb == n ? 0 : 1;
  if (wb && nb != n) fprintf(stderr, PROG ": %zu values in %s, %zu in %s\n", n, argv[1], nb, argv[2]);
  for (size_t i = 0; i < n && status == 0; ++i) {
    bool in_a = mask_a[i] != 0.0f, in_b = mask_b[i] != 0.0f;
    double level = wb[i] > 0.0f ? snr / sqrt((double)wb[i]) : (double)INFINITY, v = (double)value[i];
    bool resolved = v >= level * (1.0 - 1e-6), unresolved = v < level * (1.0 + 1e-6);
    if ((in_b && !in_a) || (in_b && !resolved) || (in_a && !in_b && !unresolved)) {
      fprintf(stderr, PROG ": value %zu = %.9g, residual's error %.9g: kept by A %d, by B %d\n", i, v, level / snr,
              (int)in_a, (int)in_b);
      status = 1;
    }
    kept_a += in_a;
    kept_b += in_b;
  }
  if (status == 0 && !(kept_b < kept_a)) {
    fprintf(stderr, PROG ": B keeps %zu values, A %zu: the residual's test left none more out\n", kept_b, kept_a);
    status = 1;
  }
  if (status == 0) printf("%zu values: the data's test keeps %zu, the residual's %zu\n", n, kept_a, kept_b);
  hetinv_image_destroy(&a);
  hetinv_image_destroy(&b);
  hetinv_context_destroy(&ctx);
  return status;
}
