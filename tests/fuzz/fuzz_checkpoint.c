/* libFuzzer harness of the checkpoint reader (hv_checkpoint_restore).
 *
 * An input is one byte choosing one of four configured runs (the four
 * methods; plateau windows on two of them) followed by a checkpoint. The
 * harness recomputes the checkpoint's FNV-1a checksum, so that the fuzzer
 * reaches the fields instead of stopping at the checksum, and restores it
 * into a fresh optimizer of that run. A refused checkpoint must leave the
 * optimizer unstarted and empty; an accepted one must be usable: its
 * result and π are read and the run continues for one iteration.
 *
 * The seed corpus (corpus/checkpoint) is written by the library itself:
 * with HETINV_FUZZ_CHECKPOINT_SEEDS=<dir> in the environment, the harness
 * runs each configuration, saves checkpoints in its first and second stage
 * to <dir> and exits. The runs are deterministic (one thread, fixed seed
 * and measured values), so the seeds match the harness's fingerprints;
 * regenerate them when the checkpoint format or the fingerprint changes
 * (the test fuzz_checkpoint_seeds runs them with
 * HETINV_FUZZ_CHECKPOINT_EXPECT_VALID set, which makes a refused input
 * fail, so a stale corpus is noticed). corpus/checkpoint/regression_*
 * are the fuzzer's findings, kept so that the smoke run retries them. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hetinv/hetinv.h"
#include "optimize/checkpoint_internal.h"

int LLVMFuzzerInitialize(int *argc, char ***argv);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define CHECK(cond) \
  do { \
    if (!(cond)) __builtin_trap(); \
  } while (0)

enum { CONFIGS = 4 };

typedef struct problem {
  hetinv_context_t *ctx;
  hetinv_medium_t *initial;
  hetinv_emitter_t *beams[2];
  hetinv_sensor_t *reflect;
  hetinv_pathlength_t *steady;
  hetinv_measurements_t *set;
  hetinv_estimator_t *est;
  hetinv_param_map_t *coarse, *identity;
} problem_t;

static problem_t P;
static int expect_valid; /* HETINV_FUZZ_CHECKPOINT_EXPECT_VALID: every input must resume */

/* Aborts on a failure of the setup (not of the code under test). */
static void ok(hetinv_result_t r, const char *what) {
  if (r != HETINV_SUCCESS) {
    fprintf(stderr, "fuzz_checkpoint: %s: %s\n", what, hetinv_context_last_error_message(NULL));
    abort();
  }
}

/* A 2 x 1 x 2 medium, two pencil beams, a reflection sensor of 2 x 1
 * pixels, constant measured values, tiny renders. */
static void problem_init(void) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  init.seed = 7;
  ok(hetinv_context_create(&init, &P.ctx), "context");
  ok(hetinv_medium_create(P.ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){2, 1, 2}, &P.initial),
     "medium");
  ok(hetinv_medium_fill(P.initial, 0.2, 8.0, 0.0), "fill");
  ok(hetinv_medium_set_ior(P.initial, 1.3, 1.0), "ior");
  ok(hetinv_medium_commit(P.initial), "commit");
  ok(hetinv_sensor_create_orthographic(P.initial, HETINV_FACE_Z_MIN, (double[]){0, 0, -1}, (double[]){0, 0},
                                       (double[]){0.5, 1}, 2, 1, &P.reflect),
     "sensor");
  ok(hetinv_pathlength_create_steady(P.ctx, &P.steady), "pathlength");
  ok(hetinv_measurements_create(P.ctx, &P.set), "set");
  for (int e = 0; e < 2; ++e) {
    ok(hetinv_emitter_create_ideal(P.initial, (double[]){0.25 + 0.5 * e, 0.5, -1}, (double[]){0, 0, 1},
                                   &P.beams[e]),
       "emitter");
    ok(hetinv_measurements_add(P.set, P.beams[e], P.reflect, P.steady, NULL), "row");
  }
  size_t n = hetinv_measurements_value_count(P.set);
  double values[16];
  CHECK(n <= 16);
  for (size_t i = 0; i < n; ++i) values[i] = 0.05;
  ok(hetinv_measurements_set_values(P.set, values, NULL, n), "values");
  ok(hetinv_estimator_create(P.ctx, &P.est), "estimator");
  ok(hetinv_estimator_set_param(P.est, HETINV_ESTIMATOR_PHOTONS, 16), "photons");
  ok(hetinv_estimator_set_param(P.est, HETINV_ESTIMATOR_BATCHES, 2), "batches");
  ok(hetinv_param_map_create_coarse(P.initial, (int32_t[]){1, 1, 1}, HETINV_FREE(HETINV_PARAM_SIGMA_S), &P.coarse),
     "coarse map");
  ok(hetinv_param_map_create_identity(P.initial, HETINV_FREE(HETINV_PARAM_SIGMA_S), &P.identity), "identity map");
}

/* Configuration c: method c, coarse (4 iterations) then per voxel (4),
 * σs in [1, 10], window 3; plateau window 1 for the odd ones, minibatches
 * of one emitter for c >= 2. */
static hetinv_optimizer_t *make_optimizer(int c) {
  hetinv_optimizer_t *opt = NULL;
  ok(hetinv_optimizer_create(P.ctx, P.set, P.initial, &opt), "optimizer");
  static const int methods[CONFIGS] = {HETINV_METHOD_ADADELTA, HETINV_METHOD_SGD, HETINV_METHOD_ADAGRAD,
                                       HETINV_METHOD_ADAM};
  ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 1.0, 10.0), "bounds");
  ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_METHOD, methods[c]), "method");
  ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_AVERAGE_WINDOW, 3), "window");
  ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, c % 2), "plateau");
  ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, c >= 2 ? 1 : 0), "minibatch");
  const hetinv_param_map_t *maps[2] = {P.coarse, P.identity};
  for (int s = 0; s < 2; ++s) {
    hetinv_stage_t st = {sizeof st, maps[s], 4, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
    ok(hetinv_optimizer_add_stage(opt, &st), "stage");
  }
  return opt;
}

/* --- seeds ---------------------------------------------------------------- */

static int stop_after(const hetinv_progress_t *p, void *user) {
  return p->iteration >= *(const int64_t *)user;
}

/* Saves the run's state to <dir>/method<c>_iteration<n>, prefixed with the
 * configuration's byte. */
static void write_seed(const char *dir, int c, const hetinv_optimizer_t *opt, int64_t n) {
  char tmp[4096], path[4096];
  snprintf(tmp, sizeof tmp, "%s/seed.tmp", dir);
  snprintf(path, sizeof path, "%s/method%d_iteration%d", dir, c, (int)n);
  ok(hetinv_optimizer_save(opt, tmp), "save");
  FILE *in = fopen(tmp, "rb"), *out = fopen(path, "wb");
  CHECK(in && out);
  fputc(c, out);
  for (int ch; (ch = fgetc(in)) != EOF;) fputc(ch, out);
  fclose(in);
  CHECK(fclose(out) == 0);
  remove(tmp);
}

/* Each configuration stopped after 2 iterations (in stage 0) and after 6
 * (in stage 1, or at the end when plateaus ended the stages early). */
static void write_seeds(const char *dir) {
  for (int c = 0; c < CONFIGS; ++c) {
    hetinv_optimizer_t *opt = make_optimizer(c);
    for (int64_t stop = 2; stop <= 6; stop += 4) {
      ok(hetinv_optimizer_set_progress(opt, stop_after, &stop), "progress");
      ok(hetinv_optimizer_run(opt, P.est, NULL), "run");
      write_seed(dir, c, opt, stop);
    }
    hetinv_optimizer_destroy(&opt);
  }
}

int LLVMFuzzerInitialize(int *argc, char ***argv) {
  (void)argc;
  (void)argv;
  problem_init();
  expect_valid = getenv("HETINV_FUZZ_CHECKPOINT_EXPECT_VALID") != NULL;
  const char *dir = getenv("HETINV_FUZZ_CHECKPOINT_SEEDS");
  if (dir != NULL) {
    write_seeds(dir);
    exit(0);
  }
  return 0;
}

/* --- one input -------------------------------------------------------------- */

static int stop_now(const hetinv_progress_t *p, void *user) {
  (void)p;
  (void)user;
  return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  if (size < 1) return 0;
  int c = data[0] % CONFIGS;
  size_t len = size - 1;
  unsigned char *ckpt = malloc(len ? len : 1);
  CHECK(ckpt != NULL);
  if (len) memcpy(ckpt, data + 1, len);
  if (len >= 8) {
    uint64_t sum = hv_fnv1a(HV_FNV_OFFSET, ckpt, len - 8);
    memcpy(ckpt + len - 8, &sum, 8);
  }
  hetinv_optimizer_t *opt = make_optimizer(c);
  hetinv_result_t r = hv_checkpoint_restore(opt, ckpt, len, "the fuzz input");
  free(ckpt);
  size_t n = 99;
  if (r != HETINV_SUCCESS && expect_valid) {
    fprintf(stderr, "fuzz_checkpoint: a seed was refused: %s\n", hetinv_context_last_error_message(NULL));
    abort();
  }
  if (r != HETINV_SUCCESS) {
    CHECK(r == HETINV_ERROR_CORRUPT_FILE || r == HETINV_ERROR_INVALID_ARGUMENT || r == HETINV_ERROR_UNSUPPORTED);
    CHECK(hetinv_optimizer_losses(opt, &n) == NULL && n == 0);
    CHECK(hetinv_optimizer_get_pi(opt, 0, (double[1]){0}, 1) == HETINV_ERROR_INVALID_STATE);
  } else {
    /* Usable: π inside the box, a valid result, one more iteration. */
    double pi[4], avg[4];
    size_t k = 0;
    for (size_t kk = 1; kk <= 4 && k == 0; kk *= 4) {
      if (hetinv_optimizer_get_pi(opt, 0, pi, kk) == HETINV_SUCCESS) k = kk;
    }
    CHECK(k != 0);
    CHECK(hetinv_optimizer_get_pi(opt, 1, avg, k) == HETINV_SUCCESS);
    for (size_t i = 0; i < k; ++i) CHECK(pi[i] >= 1.0 && pi[i] <= 10.0 && avg[i] >= 1.0 && avg[i] <= 10.0);
    hetinv_medium_t *m = NULL;
    CHECK(hetinv_optimizer_result(opt, &m) == HETINV_SUCCESS);
    hetinv_medium_destroy(&m);
    ok(hetinv_optimizer_set_progress(opt, stop_now, NULL), "progress");
    /* The estimator's tunables are compared only now: a forged but valid
     * one is refused here, by name. */
    r = hetinv_optimizer_run(opt, P.est, NULL);
    CHECK(r == HETINV_SUCCESS || r == HETINV_ERROR_INVALID_ARGUMENT);
  }
  hetinv_optimizer_destroy(&opt);
  return 0;
}
