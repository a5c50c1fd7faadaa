/* hetinv-bench-iteration: one optimisation iteration of the built-in
 * reduced Fig. 4 scene (hetinv-reconstruct's defaults: 16 of 72 sources
 * per minibatch, 2000 photons each, four steady-state cameras), split into
 * what it does, each timed alone on the same medium, the truth, where the
 * optimizer starts too (a uniform start would take the uniform grid's fast
 * path for the parts but not for the iterations, which leave it at once;
 * every part on every source, then
 * scaled to a minibatch's share of them, since minibatches are random and
 * sources differ in cost):
 *
 *   render     the forward pass of the minibatch (hetinv_estimator_render)
 *   gradient   the gradient pass (hetinv_estimator_gradient, every voxel free)
 *   loss       both, as the optimizer calls them (hetinv_estimator_loss_gradient)
 *   iteration  a whole optimizer iteration (hetinv_optimizer_run on a stage
 *              of N iterations at the voxel grid, divided by N): minibatch
 *              set, medium update, loss gradient, step, averaging
 *
 * and derived: reductions = loss − render − gradient (buffers, the plan and
 * the cross-thread sums both passes make again inside the loss call),
 * bookkeeping = iteration − loss (the optimizer's own work), and paths/s of
 * the iteration (2 paths per photon: rendered, then traced for the
 * gradient) against the render's photons/s on the same minibatch and medium
 * (the target: within 1.5×).
 *
 *   hetinv-bench-iteration [--threads N] [--photons N] [--iterations N] [--repeat R] [--grid N]
 *
 * --grid N: an N × 1 × N section instead of 6 × 1 × 6 (with the same
 * photons, the cost per iteration should not grow with the grid).
 * Output: one line per figure, "iteration name=value ...". Medians of R
 * rounds (default 5), the parts timed in turn in each round. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "recon.h"

static double now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static int cmp(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double median(double *v, int n) {
  qsort(v, (size_t)n, sizeof *v, cmp);
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static int fail(hetinv_context_t *ctx, const char *what) {
  /* NULL: the thread's last failure, which names the value (hetinv_context_create's). */
  fprintf(stderr, "hetinv-bench-iteration: %s: %s\n", what, hetinv_context_last_error_message(ctx));
  return 1;
}

static int parse(const char *opt, const char *v, long lo, long hi, long *out) {
  char *end = NULL;
  errno = 0;
  long x = v ? strtol(v, &end, 10) : 0;
  if (v == NULL || *v == '\0' || *end != '\0' || errno != 0 || x < lo || x > hi) {
    fprintf(stderr, "hetinv-bench-iteration: %s: '%s' is not an integer from %ld to %ld\n", opt, v ? v : "", lo, hi);
    return -1;
  }
  *out = x;
  return 0;
}

enum { RENDER, GRADIENT, LOSS, ITERATION, PARTS };

int main(int argc, char **argv) {
  long threads = 0, photons = -1, iterations = 20, repeat = 5, grid = 6;
  static const char usage[] =
      "usage: hetinv-bench-iteration [--threads N] [--photons N] [--iterations N] [--repeat R] [--grid N]\n";
  for (int i = 1; i < argc; i += 2) { /* every option takes a value */
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
    if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
      fputs(usage, stdout);
      return 0;
    }
    long *dst = strcmp(a, "--threads") == 0 ? &threads : strcmp(a, "--photons") == 0 ? &photons
              : strcmp(a, "--iterations") == 0 ? &iterations : strcmp(a, "--repeat") == 0 ? &repeat
              : strcmp(a, "--grid") == 0 ? &grid : NULL;
    long lo = dst == &threads ? 0 : dst == &grid ? 2 : 1;
    long hi = dst == &threads ? HETINV_MAX_THREADS : dst == &grid ? 64 : dst == &repeat ? 64 : 100000000;
    if (dst == NULL) {
      fprintf(stderr, "hetinv-bench-iteration: unknown option '%s'\n%s", a, usage);
      return 2;
    }
    if (parse(a, v, lo, hi, dst) < 0) return 2;
  }
  recon_scene_t sc;
  recon_scene_default(&sc);
  sc.grid[0] = sc.grid[2] = (int32_t)grid;
  sc.size = 0.1 * (double)grid; /* the scene's 0.1 mm voxels */
  sc.truth_photons = 200;       /* the data only need to exist */
  if (photons > 0) sc.photons = photons;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc.seed;
  init.thread_count = (int32_t)threads;
  hetinv_context_t *ctx = NULL;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return fail(NULL, "context");
  hetinv_medium_t *truth = NULL;
  recon_imaging_t im;
  memset(&im, 0, sizeof im);
  if (recon_truth_create(ctx, &sc, &truth) != HETINV_SUCCESS) return fail(ctx, "truth");
  if (recon_imaging_build(ctx, truth, &sc, &im) != HETINV_SUCCESS) return fail(ctx, "imaging");
  if (recon_simulate(ctx, &sc, truth, &im) != HETINV_SUCCESS) return fail(ctx, "simulation");
  /* The parts are timed on every emitter and scaled to a minibatch's
   * share: the optimizer's minibatches are random, and emitters differ in
   * cost (where their light goes, how often it scatters). */
  int32_t mb = sc.minibatch < im.emitter_count ? sc.minibatch : im.emitter_count;
  const double share = (double)mb / (double)im.emitter_count;
  const hetinv_measurements_t *all = im.set;
  size_t n = hetinv_measurements_value_count(all);
  double *values = calloc(n, sizeof *values), *cot = calloc(n, sizeof *cot);
  hetinv_param_map_t *map = NULL;
  if (hetinv_param_map_create_identity(truth, HETINV_FREE_ALL, &map) != HETINV_SUCCESS) return fail(ctx, "map");
  size_t k = hetinv_param_map_size(map);
  double *grad = calloc(k, sizeof *grad);
  if (!values || !cot || !grad) return fail(NULL, "out of memory");
  for (size_t i = 0; i < n; ++i) cot[i] = 1.0 + 0.001 * (double)(i % 7);
  hetinv_estimator_t *est = NULL;
  if (hetinv_estimator_create(ctx, &est) != HETINV_SUCCESS ||
      hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)sc.photons) != HETINV_SUCCESS ||
      hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, sc.batches) != HETINV_SUCCESS) {
    return fail(ctx, "estimator");
  }
  printf("iteration scene=\"reduced Fig. 4\" grid=%ldx1x%ld sources=%d minibatch=%d photons=%lld rows=%d values=%zu "
         "threads=%d iterations=%ld repeat=%ld\n",
         grid, grid, (int)im.emitter_count, (int)mb, (long long)sc.photons, (int)hetinv_measurements_row_count(all), n,
         (int)hetinv_context_thread_count(ctx), iterations, repeat);
  double t[PARTS][64];
  for (long round = 0; round < repeat; ++round) {
    double t0 = now();
    if (hetinv_estimator_render(est, truth, all, values, NULL, NULL, n) != HETINV_SUCCESS) return fail(ctx, "render");
    double t1 = now();
    if (hetinv_estimator_gradient(est, truth, all, cot, n, map, grad, NULL, k) != HETINV_SUCCESS) return fail(ctx, "gradient");
    double t2 = now();
    double loss = 0.0;
    if (hetinv_estimator_loss_gradient(est, truth, all, map, &loss, NULL, grad, k) != HETINV_SUCCESS) return fail(ctx, "loss");
    double t3 = now();
    /* A whole iteration: the optimizer on the full set, minibatches of the
     * scene's size, one stage at the voxel grid. */
    hetinv_optimizer_t *opt = NULL;
    hetinv_stage_t stage = {sizeof stage, map, (int32_t)iterations, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
    hetinv_result_t r = hetinv_optimizer_create(ctx, im.set, truth, &opt);
    for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) r = hetinv_optimizer_set_bounds(opt, p, sc.bounds_lo[p], sc.bounds_hi[p]);
    if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, sc.minibatch);
    if (r == HETINV_SUCCESS) r = hetinv_optimizer_add_stage(opt, &stage);
    double t4 = now();
    hetinv_stop_reason_t why;
    if (r == HETINV_SUCCESS) r = hetinv_optimizer_run(opt, est, &why);
    double t5 = now();
    hetinv_optimizer_destroy(&opt);
    if (r != HETINV_SUCCESS) return fail(ctx, "optimizer");
    t[RENDER][round] = (t1 - t0) * share;
    t[GRADIENT][round] = (t2 - t1) * share;
    t[LOSS][round] = (t3 - t2) * share;
    t[ITERATION][round] = (t5 - t4) / (double)iterations;
  }
  double m[PARTS];
  for (int p = 0; p < PARTS; ++p) m[p] = median(t[p], (int)repeat);
  double paths = (double)mb * (double)sc.photons;
  printf("iteration render_seconds=%.5f photons_per_second=%.0f\n", m[RENDER], paths / m[RENDER]);
  printf("iteration gradient_seconds=%.5f ratio_gradient_over_render=%.3f\n", m[GRADIENT], m[GRADIENT] / m[RENDER]);
  printf("iteration loss_gradient_seconds=%.5f reductions_seconds=%.5f\n", m[LOSS], m[LOSS] - m[RENDER] - m[GRADIENT]);
  printf("iteration iteration_seconds=%.5f bookkeeping_seconds=%.5f\n", m[ITERATION], m[ITERATION] - m[LOSS]);
  printf("iteration paths_per_second=%.0f render_over_iteration_paths_per_second=%.3f (target <= 1.5)\n",
         2.0 * paths / m[ITERATION], (paths / m[RENDER]) / (2.0 * paths / m[ITERATION]));
  free(values);
  free(cot);
  free(grad);
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&truth);
  recon_imaging_release(&im);
  hetinv_context_destroy(&ctx);
  return 0;
}
