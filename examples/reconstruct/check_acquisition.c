/* hetinv-acquisition-check: test helper. Simulates a scene's acquisition as
 * hetinv-reconstruct does and checks that the standard error stored with
 * each value describes how far the value lies from the truth's expected
 * value: z = (v − I) / sqrt(se² + se_I²), with I a reference render of the
 * truth at REF_PHOTONS per emitter on a stream of its own (se_I its error,
 * so the check holds at any REF_PHOTONS). Over the lit values mean(z²) must
 * be 1 within 4 standard errors of that mean. Standard errors that left
 * out the truth render's own Monte Carlo error gave mean(z²) far above 1.
 *
 *   usage: hetinv-acquisition-check SCENE.json REF_PHOTONS
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "recon.h"

#define PROG "hetinv-acquisition-check"
/* Neither the data's stream (acquire.c) nor the optimizer's. */
#define REFERENCE_STREAM 50000

/* Diagnostics (printed, not checked) over the values the fit uses (mask
 * 1, lit): how many lie beyond 3 standard errors, and the mean of z (0
 * when the data are unbiased; the mask's selection on the data's own draw
 * biases it up). A weighted offset Σ w (v − I) I / Σ w I² was tried and
 * dropped: one dim value with a tiny standard error, whose reference
 * render caught a rare path, rules it. */
static void print_fitted(const double *v, const uint8_t *mask, const double *se, const double *ref,
                         const double *ref_se, size_t n) {
  double sz = 0.0, sz2 = 0.0;
  size_t count = 0, beyond = 0;
  for (size_t i = 0; i < n; ++i) {
    double s2 = se[i] * se[i] + ref_se[i] * ref_se[i];
    if (!mask[i] || !(ref[i] > 0.0) || !(s2 > 0.0)) continue;
    double z = (v[i] - ref[i]) / sqrt(s2);
    sz += z;
    sz2 += z * z;
    beyond += fabs(z) > 3.0;
    ++count;
  }
  if (count < 2) return;
  double mz = sz / (double)count, sdz = sqrt(fmax(sz2 / (double)count - mz * mz, 0.0) / (double)(count - 1));
  printf("fitted values (mask 1): %zu; beyond 3 standard errors %zu (%.2f %%; 0.27 %% for normal errors); "
         "mean z %+.4f +- %.4f\n",
         count, beyond, 100.0 * (double)beyond / (double)count, mz, sdz);
}

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: " PROG " SCENE.json REF_PHOTONS\n");
    return 2;
  }
  int64_t ref_photons = 0;
  if (recon_parse_count(PROG, "REF_PHOTONS", argv[2], 1, INT64_C(1) << 40, &ref_photons) < 0) return 2;
  recon_scene_t sc;
  recon_scene_default(&sc);
  char msg[2048];
  if (recon_scene_read(argv[1], &sc, msg, sizeof msg) != 0) {
    fprintf(stderr, PROG ": %s\n", msg);
    return 2;
  }
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc.seed;
  init.thread_count = sc.threads;
  hetinv_context_t *ctx = NULL;
  hetinv_medium_t *truth = NULL;
  hetinv_estimator_t *est = NULL;
  recon_imaging_t im = {0};
  double *ref = NULL, *ref_se = NULL;
  int status = 1;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return recon_fail(PROG, NULL, "context");
  hetinv_result_t r = recon_truth_create(ctx, &sc, &truth);
  if (r == HETINV_SUCCESS) r = recon_imaging_build(ctx, truth, &sc, &im);
  if (r == HETINV_SUCCESS) r = recon_simulate(ctx, &sc, truth, &im);
  size_t n = r == HETINV_SUCCESS ? hetinv_measurements_value_count(im.set) : 0;
  if (r == HETINV_SUCCESS) {
    ref = calloc(n, sizeof *ref);
    ref_se = calloc(n, sizeof *ref_se);
    if (ref == NULL || ref_se == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &est);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)ref_photons);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, REFERENCE_STREAM);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, truth, im.set, ref, ref_se, NULL, n);
  if (r != HETINV_SUCCESS) {
    recon_fail(PROG, ctx, "simulation");
  } else {
    const double *v = hetinv_measurements_values(im.set), *se = hetinv_measurements_std_errors(im.set);
    double sum = 0.0, sum2 = 0.0;
    size_t count = 0;
    for (size_t i = 0; i < n; ++i) {
      double s2 = se[i] * se[i] + ref_se[i] * ref_se[i];
      if (!(ref[i] > 0.0) || !(s2 > 0.0)) continue; /* dark values: read noise alone, no render */
      double z2 = (v[i] - ref[i]) * (v[i] - ref[i]) / s2;
      sum += z2;
      sum2 += z2 * z2;
      ++count;
    }
    double mean = count ? sum / (double)count : (double)NAN;
    double sd = count > 1 ? sqrt(fmax(sum2 / (double)count - mean * mean, 0.0) / (double)(count - 1)) : (double)NAN;
    bool ok = count > 1 && fabs(mean - 1.0) <= 4.0 * sd;
    printf("mean z^2 = %.4f +- %.4f over %zu values (1 when the standard errors describe the data): %s\n", mean, sd,
           count, ok ? "ok" : "FAILED");
    print_fitted(v, hetinv_measurements_mask(im.set), se, ref, ref_se, n);
    status = ok ? 0 : 1;
  }
  free(ref);
  free(ref_se);
  hetinv_estimator_destroy(&est);
  recon_imaging_release(&im);
  hetinv_medium_destroy(&truth);
  hetinv_context_destroy(&ctx);
  return status;
}
