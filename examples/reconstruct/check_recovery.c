/* hetinv-recovery-check: test helper. Compares a recovered volume with the
 * truth, both as .vol files (<prefix>sigma_a.vol, ...sigma_s.vol, ...g.vol),
 * and prints the mean and max relative error over the voxels of σa, of the
 * reduced scattering coefficient σs(1 − g), of σs and of g; fails if a
 * mean error exceeds its tolerance (a negative tolerance: not checked).
 *
 *   usage: hetinv-recovery-check TRUTH_PREFIX RECOVERED_PREFIX
 *                                TOL_SIGMA_A TOL_REDUCED TOL_SIGMA_S TOL_G
 */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>

#include <hetinv/hetinv.h>

/* The three parameters of a prefix, into v[3] (malloc'd, n values each). */
static int read_volume(hetinv_context_t *ctx, const char *prefix, float *v[3], size_t *n) {
  static const char *const names[3] = {"sigma_a", "sigma_s", "g"};
  for (int p = 0; p < 3; ++p) {
    char path[4096];
    snprintf(path, sizeof path, "%s%s.vol", prefix, names[p]);
    hetinv_vol_header_t h;
    if (hetinv_vol_read_header(ctx, path, &h) != HETINV_SUCCESS) goto fail;
    size_t count = (size_t)h.dims[0] * (size_t)h.dims[1] * (size_t)h.dims[2];
    if (p > 0 && count != *n) {
      fprintf(stderr, "hetinv-recovery-check: %s: %zu voxels, expected %zu\n", path, count, *n);
      return -1;
    }
    *n = count;
    v[p] = malloc(count * sizeof(float));
    if (v[p] == NULL || h.channels != 1 || hetinv_vol_read(ctx, path, &h, v[p], count) != HETINV_SUCCESS) goto fail;
    continue;
  fail:
    fprintf(stderr, "hetinv-recovery-check: %s: %s\n", path, hetinv_context_last_error_message(ctx));
    return -1;
  }
  return 0;
}

int main(int argc, char **argv) {
  if (argc != 7) {
    fprintf(stderr, "usage: %s TRUTH_PREFIX RECOVERED_PREFIX TOL_SIGMA_A TOL_REDUCED TOL_SIGMA_S TOL_G\n", argv[0]);
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  float *t[3] = {NULL, NULL, NULL}, *r[3] = {NULL, NULL, NULL};
  size_t n = 0, m = 0;
  int status = 1;
  if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS || read_volume(ctx, argv[1], t, &n) < 0 ||
      read_volume(ctx, argv[2], r, &m) < 0) {
    goto done;
  }
  if (n != m || n == 0) {
    fprintf(stderr, "hetinv-recovery-check: %zu voxels in the truth, %zu in the recovery\n", n, m);
    goto done;
  }
  static const char *const labels[4] = {"sigma_a", "sigma_s(1-g)", "sigma_s", "g"};
  status = 0;
  for (int q = 0; q < 4; ++q) {
    double sum = 0.0, mx = 0.0;
    for (size_t i = 0; i < n; ++i) {
      double a, b;
      switch (q) {
        case 0: a = (double)t[0][i]; b = (double)r[0][i]; break;
        case 1: a = (double)t[1][i] * (1.0 - (double)t[2][i]); b = (double)r[1][i] * (1.0 - (double)r[2][i]); break;
        case 2: a = (double)t[1][i]; b = (double)r[1][i]; break;
        default: a = (double)t[2][i]; b = (double)r[2][i]; break;
      }
      double e = fabs(b - a) / fabs(a);
      sum += e;
      mx = fmax(mx, e);
    }
    double tol = atof(argv[3 + q]), mean = sum / (double)n;
    bool bad = tol >= 0.0 && !(mean <= tol);
    printf("%-13s mean relative error %6.2f %%  max %6.2f %%", labels[q], 100.0 * mean, 100.0 * mx);
    if (tol >= 0.0) printf("  %s %.3g %%", bad ? "ABOVE the tolerance" : "tolerance", 100.0 * tol);
    printf("\n");
    if (bad) status = 1;
  }
done:
  for (int p = 0; p < 3; ++p) {
    free(t[p]);
    free(r[p]);
  }
  hetinv_context_destroy(&ctx);
  return status;
}
