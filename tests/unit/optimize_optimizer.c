/* The optimizer: tunables and bounds with their exact errors, one step of
 * every method against a hand computation (white-box), descent of every
 * method on a tiny problem, box projection, frozen entries and masked
 * values, minibatch reproducibility, stopping rules and progress,
 * multi-resolution hand-over, checkpoints (a child process killed half-way
 * by SIGKILL, resumed in the parent, compared bitwise with an uninterrupted
 * run; refused configurations; damaged files; forged files with a valid
 * checksum, refused field by field), layer-wise stages and NULL
 * arguments.
 *
 * Scenes are a 1 mm cube of 2 x 1 x 2 (or 3 x 1 x 3) voxels, η = 1.3, a few
 * pencil beams and small orthographic sensors, a few hundred photons per
 * emitter, so every test runs in a fraction of a second under ASan. The
 * contexts use one thread: the checkpoint tests fork(), and an OpenMP
 * runtime that has started worker threads is not fork-safe. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <signal.h>
#include <stdbool.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <dirent.h>

#include "test_support.h"

#include "optimize/optimizer_internal.h"

#define SS HETINV_FREE(HETINV_PARAM_SIGMA_S)
#define NaN ((double)NAN)
#define Inf ((double)INFINITY)

/* |a - b| <= tol, printing both on failure. */
#define assert_close(a, b, tol) \
  do { \
    double a_ = (a), b_ = (b); \
    if (!(fabs(a_ - b_) <= (tol))) { \
      print_error("%s = %.17g, expected %s = %.17g (tolerance %g)\n", #a, a_, #b, b_, (double)(tol)); \
      fail(); \
    } \
  } while (0)

enum { MAX_EMITTERS = 4, MAX_K = 16, MAX_LOSSES = 256, MAX_VOXELS = 16 };

static const double TRUTH_SIGMA_A = 0.2, TRUTH_SIGMA_S = 3.0, START_SIGMA_S = 8.0;
static const double SIGMA_LO = 1.0, SIGMA_HI = 10.0; /* the paper's box */

/* ------------------------------------------------------------------------ */
/* A tiny problem: a uniform (or, for layer-wise tests, layered) medium, pencil
 * beams entering face Z_MIN along +z, an orthographic reflection sensor on
 * Z_MIN and a transmission sensor on Z_MAX (2 x 1 pixels each). With
 * `bins`, the rows are reflection only and resolved in pathlength (16 box
 * bins of 0.25 mm): the frontlit set of the layer-wise procedure. */

typedef struct problem {
  hetinv_context_t *ctx;
  int32_t dims[3];
  int emitters;
  hetinv_medium_t *truth, *initial;
  hetinv_emitter_t *beams[MAX_EMITTERS];
  double beam_x[MAX_EMITTERS];
  hetinv_sensor_t *reflect, *transmit;
  hetinv_pathlength_t *pathlength;
  hetinv_measurements_t *set;
  hetinv_estimator_t *est;
  hetinv_param_map_t *coarse, *identity; /* σs free: 1 x 1 x 1, and per voxel */
  size_t count;
} problem_t;

enum { BINS = 16 };
static const double BIN_WIDTH = 0.25;

static hetinv_context_t *make_context(uint64_t seed) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  init.seed = seed;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  return ctx;
}

static hetinv_medium_t *make_medium(hetinv_context_t *ctx, const int32_t dims[3], double sigma_s) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, dims, &m));
  assert_ok(hetinv_medium_fill(m, TRUTH_SIGMA_A, sigma_s, 0.0));
  assert_ok(hetinv_medium_set_ior(m, 1.3, 1.0));
  return m;
}

static void problem_init(problem_t *p, uint64_t seed, int32_t nx, int32_t nz, int emitters, bool bins) {
  *p = (problem_t){.ctx = make_context(seed), .dims = {nx, 1, nz}, .emitters = emitters};
  p->truth = make_medium(p->ctx, p->dims, TRUTH_SIGMA_S);
  if (bins) { /* layered truth: σs grows with depth */
    for (int32_t z = 0; z < nz; ++z) {
      for (int32_t x = 0; x < nx; ++x) {
        assert_ok(hetinv_medium_set_voxel(p->truth, x, 0, z, TRUTH_SIGMA_A, 2.0 + z, 0.0));
      }
    }
  }
  assert_ok(hetinv_medium_commit(p->truth));
  p->initial = make_medium(p->ctx, p->dims, START_SIGMA_S);
  assert_ok(hetinv_medium_commit(p->initial));

  const double *pixel = nx == 3 ? (double[]){1.0 / 3, 1} : (double[]){0.5, 1};
  int32_t width = nx == 3 ? 3 : 2;
  assert_ok(hetinv_sensor_create_orthographic(p->truth, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, pixel, width, 1, &p->reflect));
  assert_ok(hetinv_sensor_create_orthographic(p->truth, HETINV_FACE_Z_MAX, (double[]){0, 0, 1},
                                              (double[]){0, 0}, pixel, width, 1, &p->transmit));
  if (bins) {
    double centres[BINS];
    for (int i = 0; i < BINS; ++i) centres[i] = (i + 0.5) * BIN_WIDTH;
    assert_ok(hetinv_pathlength_create_bins(p->ctx, HETINV_WINDOW_BOX, BINS, centres, BIN_WIDTH,
                                            &p->pathlength));
  } else {
    assert_ok(hetinv_pathlength_create_steady(p->ctx, &p->pathlength));
  }
  assert_ok(hetinv_measurements_create(p->ctx, &p->set));
  for (int e = 0; e < emitters; ++e) {
    p->beam_x[e] = (e + 0.5) / emitters;
    assert_ok(hetinv_emitter_create_ideal(p->truth, (double[]){p->beam_x[e], 0.5, -1},
                                          (double[]){0, 0, 1}, &p->beams[e]));
    assert_ok(hetinv_measurements_add(p->set, p->beams[e], p->reflect, p->pathlength, NULL));
    if (!bins) assert_ok(hetinv_measurements_add(p->set, p->beams[e], p->transmit, p->pathlength, NULL));
  }
  p->count = hetinv_measurements_value_count(p->set);

  /* The measured values: the truth rendered once with more photons (epoch 0). */
  assert_ok(hetinv_estimator_create(p->ctx, &p->est));
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 2000));
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_BATCHES, 2));
  double *values = calloc(p->count, sizeof *values);
  assert_non_null(values);
  assert_ok(hetinv_estimator_render(p->est, p->truth, p->set, values, NULL, NULL, p->count));
  assert_ok(hetinv_measurements_set_values(p->set, values, NULL, p->count));
  free(values);
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 100));

  assert_ok(hetinv_param_map_create_coarse(p->initial, (int32_t[]){1, 1, 1}, SS, &p->coarse));
  assert_ok(hetinv_param_map_create_identity(p->initial, SS, &p->identity));
}

static void problem_release(problem_t *p) {
  hetinv_param_map_destroy(&p->coarse);
  hetinv_param_map_destroy(&p->identity);
  hetinv_estimator_destroy(&p->est);
  hetinv_measurements_destroy(&p->set);
  for (int e = 0; e < p->emitters; ++e) hetinv_emitter_destroy(&p->beams[e]);
  hetinv_sensor_destroy(&p->reflect);
  hetinv_sensor_destroy(&p->transmit);
  hetinv_pathlength_destroy(&p->pathlength);
  hetinv_medium_destroy(&p->truth);
  hetinv_medium_destroy(&p->initial);
  hetinv_context_destroy(&p->ctx);
}

/* The default problem of most tests: 2 x 1 x 2 voxels, two beams, steady. */
static int problem_setup(void **state) {
  problem_t *p = calloc(1, sizeof *p);
  if (p == NULL) return -1;
  problem_init(p, 7, 2, 2, 2, false);
  *state = p;
  return 0;
}

static int problem_teardown(void **state) {
  problem_t *p = *state;
  problem_release(p);
  free(p);
  return 0;
}

/* ------------------------------------------------------------------------ */
/* Optimizer configurations. Built without cmocka asserts (they return the
 * first failure), so that the tests can check them. */

typedef struct setup {
  int stages;
  const hetinv_param_map_t *maps[2];
  int32_t iterations[2];
  double method, minibatch, window, interval;
  double epsilon_start[2]; /* each stage's ε at its start; 0 = the tunable */
  int32_t stage_window[2];  /* each stage's averaging window; 0 = the tunable */
  double settle_epsilon[2], settle_fraction[2]; /* each stage's settling part; 0 = none */
} setup_t;

/* One coarse stage of 8 iterations, ADADELTA, every emitter, window 3. */
static setup_t coarse_setup(const problem_t *p) {
  return (setup_t){.stages = 1, .maps = {p->coarse}, .iterations = {8}, .method = HETINV_METHOD_ADADELTA,
                   .minibatch = 0, .window = 3, .interval = 1};
}

/* Coarse (4 iterations) then per voxel (4 iterations). */
static setup_t two_stage_setup(const problem_t *p) {
  return (setup_t){.stages = 2, .maps = {p->coarse, p->identity}, .iterations = {4, 4},
                   .method = HETINV_METHOD_ADADELTA, .minibatch = 0, .window = 3, .interval = 1};
}

static hetinv_result_t configure(hetinv_optimizer_t *opt, const setup_t *s) {
  hetinv_result_t r = hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, SIGMA_HI);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_METHOD, s->method);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, s->minibatch);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_AVERAGE_WINDOW, s->window);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, s->interval);
  for (int i = 0; r == HETINV_SUCCESS && i < s->stages; ++i) {
    hetinv_stage_t st = {sizeof st, s->maps[i], s->iterations[i], NULL, NULL, s->epsilon_start[i],
                         s->stage_window[i], s->settle_epsilon[i], s->settle_fraction[i]};
    r = hetinv_optimizer_add_stage(opt, &st);
  }
  return r;
}

static hetinv_optimizer_t *make_optimizer(const problem_t *p, const setup_t *s) {
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(configure(opt, s));
  return opt;
}

/* Everything a run leaves: π (last and averaged), losses, the result medium. */
typedef struct outcome {
  size_t k, loss_count, voxels;
  double pi[MAX_K], avg[MAX_K];
  double losses[MAX_LOSSES];
  double grid[HETINV_PARAM_COUNT][MAX_VOXELS];
} outcome_t;

static void capture(const hetinv_optimizer_t *opt, size_t k, outcome_t *o) {
  memset(o, 0, sizeof *o);
  o->k = k;
  assert_ok(hetinv_optimizer_get_pi(opt, 0, o->pi, k));
  assert_ok(hetinv_optimizer_get_pi(opt, 1, o->avg, k));
  const double *l = hetinv_optimizer_losses(opt, &o->loss_count);
  assert_non_null(l);
  assert_true(o->loss_count <= MAX_LOSSES);
  memcpy(o->losses, l, o->loss_count * sizeof *l);
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  o->voxels = hetinv_medium_voxel_count(m);
  assert_true(o->voxels <= MAX_VOXELS);
  for (int q = 0; q < HETINV_PARAM_COUNT; ++q) memcpy(o->grid[q], hetinv_medium_grid(m, q), o->voxels * sizeof(double));
  hetinv_medium_destroy(&m);
}

static void assert_same_outcome(const outcome_t *a, const outcome_t *b) {
  assert_int_equal(a->k, b->k);
  assert_int_equal(a->loss_count, b->loss_count);
  assert_int_equal(a->voxels, b->voxels);
  assert_memory_equal(a->pi, b->pi, sizeof a->pi);
  assert_memory_equal(a->avg, b->avg, sizeof a->avg);
  assert_memory_equal(a->losses, b->losses, sizeof a->losses);
  assert_memory_equal(a->grid, b->grid, sizeof a->grid);
}

/* Runs a configuration to its end from scratch and captures it. */
static void reference_run(const problem_t *p, const setup_t *s, size_t k, outcome_t *o) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  capture(opt, k, o);
  hetinv_optimizer_destroy(&opt);
}

/* Mean σs of a medium. */
static double mean_sigma_s(const hetinv_medium_t *m) {
  size_t v = hetinv_medium_voxel_count(m);
  const double *g = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S);
  double s = 0.0;
  for (size_t i = 0; i < v; ++i) s += g[i];
  return s / (double)v;
}

/* ------------------------------------------------------------------------ */
/* 1. Tunables and bounds. */

static void tunables_have_documented_defaults_and_bounds(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  static const struct { hetinv_optimizer_param_t id; double def, lo, hi; } expect[] = {
      {HETINV_OPTIMIZER_METHOD, HETINV_METHOD_ADADELTA, 0, HETINV_METHOD_COUNT_ - 1},
      {HETINV_OPTIMIZER_DECAY, 0.95, 0, 0.999999},
      {HETINV_OPTIMIZER_EPSILON, 0.01, 1e-12, 1},
      {HETINV_OPTIMIZER_LEARNING_RATE, 0.01, 1e-300, 1e12},
      {HETINV_OPTIMIZER_BETA1, 0.9, 0, 0.999999},
      {HETINV_OPTIMIZER_BETA2, 0.999, 0, 0.999999},
      {HETINV_OPTIMIZER_MINIBATCH, 0, 0, 2147483647.0},
      {HETINV_OPTIMIZER_ITERATIONS, 100, 1, 1e15},
      {HETINV_OPTIMIZER_TIME_BUDGET, 0, 0, 1e12},
      {HETINV_OPTIMIZER_PLATEAU_WINDOW, 0, 0, 1e9},
      {HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 0.01, 0, 1},
      {HETINV_OPTIMIZER_AVERAGE_WINDOW, 20, 1, 4096},
      {HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, 10, 1, 1e15},
      {HETINV_OPTIMIZER_COORDINATES, HETINV_COORDINATES_NATIVE, 0, HETINV_COORDINATES_COUNT_ - 1},
      {HETINV_OPTIMIZER_SMOOTHNESS, 0, 0, 1e12},
      {HETINV_OPTIMIZER_MULTISCALE, 0, 0, 100},
      {HETINV_OPTIMIZER_BOX_MARGIN, 0, 0, 1},
  };
  assert_int_equal(sizeof expect / sizeof expect[0], HETINV_OPTIMIZER_PARAM_COUNT_);
  for (size_t i = 0; i < sizeof expect / sizeof expect[0]; ++i) {
    double v = -1, lo = -1, hi = -1;
    assert_ok(hetinv_optimizer_get_param(opt, expect[i].id, &v));
    assert_true(v == expect[i].def);
    assert_ok(hetinv_optimizer_param_bounds(expect[i].id, &lo, &hi));
    assert_true(lo == expect[i].lo && hi == expect[i].hi);
    assert_true(lo <= v && v <= hi);
    /* Both bounds are accepted, and read back. */
    assert_ok(hetinv_optimizer_set_param(opt, expect[i].id, lo));
    assert_ok(hetinv_optimizer_get_param(opt, expect[i].id, &v));
    assert_true(v == lo);
    assert_ok(hetinv_optimizer_set_param(opt, expect[i].id, hi));
    assert_ok(hetinv_optimizer_get_param(opt, expect[i].id, &v));
    assert_true(v == hi);
  }
  assert_ok(hetinv_optimizer_param_bounds(HETINV_OPTIMIZER_DECAY, NULL, NULL));
  double lo = 7;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_param_bounds(-1, &lo, NULL));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_param_bounds(HETINV_OPTIMIZER_PARAM_COUNT_, &lo, NULL));
  assert_message_contains("17");
  assert_true(lo == 7);
  hetinv_optimizer_destroy(&opt);
}

static void tunables_reject_bad_values_naming_them(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  static const struct { hetinv_optimizer_param_t id; double value; const char *name, *shown; } bad[] = {
      {HETINV_OPTIMIZER_METHOD, 4, "HETINV_OPTIMIZER_METHOD", "is 4;"},
      {HETINV_OPTIMIZER_METHOD, -1, "HETINV_OPTIMIZER_METHOD", "is -1;"},
      {HETINV_OPTIMIZER_METHOD, 1.5, "HETINV_OPTIMIZER_METHOD", "is 1.5;"},
      {HETINV_OPTIMIZER_DECAY, 1.0, "HETINV_OPTIMIZER_DECAY", "is 1;"},
      {HETINV_OPTIMIZER_DECAY, -0.1, "HETINV_OPTIMIZER_DECAY", "is -0.1;"},
      {HETINV_OPTIMIZER_DECAY, NaN, "HETINV_OPTIMIZER_DECAY", "is nan;"},
      {HETINV_OPTIMIZER_EPSILON, 0, "HETINV_OPTIMIZER_EPSILON", "is 0;"},
      {HETINV_OPTIMIZER_EPSILON, 1.5, "HETINV_OPTIMIZER_EPSILON", "is 1.5;"},
      {HETINV_OPTIMIZER_LEARNING_RATE, 0, "HETINV_OPTIMIZER_LEARNING_RATE", "is 0;"},
      {HETINV_OPTIMIZER_LEARNING_RATE, Inf, "HETINV_OPTIMIZER_LEARNING_RATE", "is inf;"},
      {HETINV_OPTIMIZER_BETA1, 1, "HETINV_OPTIMIZER_BETA1", "is 1;"},
      {HETINV_OPTIMIZER_BETA2, -Inf, "HETINV_OPTIMIZER_BETA2", "is -inf;"},
      {HETINV_OPTIMIZER_MINIBATCH, 2.5, "HETINV_OPTIMIZER_MINIBATCH", "is 2.5;"},
      {HETINV_OPTIMIZER_MINIBATCH, -1, "HETINV_OPTIMIZER_MINIBATCH", "is -1;"},
      {HETINV_OPTIMIZER_MINIBATCH, 2147483648.0, "HETINV_OPTIMIZER_MINIBATCH", "is 2147483648;"},
      {HETINV_OPTIMIZER_ITERATIONS, 0, "HETINV_OPTIMIZER_ITERATIONS", "is 0;"},
      {HETINV_OPTIMIZER_ITERATIONS, 10.25, "HETINV_OPTIMIZER_ITERATIONS", "is 10.25;"},
      {HETINV_OPTIMIZER_TIME_BUDGET, -1, "HETINV_OPTIMIZER_TIME_BUDGET", "is -1;"},
      {HETINV_OPTIMIZER_PLATEAU_WINDOW, 0.5, "HETINV_OPTIMIZER_PLATEAU_WINDOW", "is 0.5;"},
      {HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 1.01, "HETINV_OPTIMIZER_PLATEAU_TOLERANCE", "is 1.01;"},
      {HETINV_OPTIMIZER_AVERAGE_WINDOW, 0, "HETINV_OPTIMIZER_AVERAGE_WINDOW", "is 0;"},
      {HETINV_OPTIMIZER_AVERAGE_WINDOW, 4097, "HETINV_OPTIMIZER_AVERAGE_WINDOW", "is 4097;"},
      {HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, 0, "HETINV_OPTIMIZER_CHECKPOINT_INTERVAL", "is 0;"},
      {HETINV_OPTIMIZER_SMOOTHNESS, -0.5, "HETINV_OPTIMIZER_SMOOTHNESS", "is -0.5;"},
      {HETINV_OPTIMIZER_SMOOTHNESS, NaN, "HETINV_OPTIMIZER_SMOOTHNESS", "is nan;"},
      {HETINV_OPTIMIZER_MULTISCALE, -0.5, "HETINV_OPTIMIZER_MULTISCALE", "is -0.5;"},
      {HETINV_OPTIMIZER_MULTISCALE, 101, "HETINV_OPTIMIZER_MULTISCALE", "is 101;"},
      {HETINV_OPTIMIZER_MULTISCALE, NaN, "HETINV_OPTIMIZER_MULTISCALE", "is nan;"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    double before = -1, after = -2;
    assert_ok(hetinv_optimizer_get_param(opt, bad[i].id, &before));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_param(opt, bad[i].id, bad[i].value));
    assert_message_contains(bad[i].name);
    assert_message_contains(bad[i].shown);
    assert_int_equal(hetinv_context_last_error_code(NULL), HETINV_ERROR_INVALID_ARGUMENT);
    assert_ok(hetinv_optimizer_get_param(opt, bad[i].id, &after));
    assert_true(before == after);
  }
  /* Integral tunables say so; the range is printed exactly. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, 0.5));
  assert_message_contains("an integer in [0, 2147483647]");
  /* Unknown tunables. */
  double v = 0;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_param(opt, -1, 0));
  assert_message_contains("-1");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PARAM_COUNT_, 0));
  assert_message_contains("17");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_get_param(opt, 99, &v));
  assert_message_contains("99");
  hetinv_optimizer_destroy(&opt);
}

static void bounds_are_validated(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  static const struct { hetinv_param_t param; double lo, hi; const char *name; } bad[] = {
      {HETINV_PARAM_SIGMA_S, 2, 2, "sigma_s"},       /* lo = hi */
      {HETINV_PARAM_SIGMA_S, 3, 2, "sigma_s"},       /* lo > hi */
      {HETINV_PARAM_SIGMA_A, -0.5, 2, "sigma_a"},    /* negative σ */
      {HETINV_PARAM_SIGMA_A, -Inf, 2, "sigma_a"},
      {HETINV_PARAM_SIGMA_A, Inf, Inf, "sigma_a"},
      {HETINV_PARAM_SIGMA_S, NaN, 2, "sigma_s"},
      {HETINV_PARAM_SIGMA_S, 1, NaN, "sigma_s"},
      {HETINV_PARAM_G, -1, 0.5, "g"},                /* g outside (-1, 1) */
      {HETINV_PARAM_G, -0.5, 1, "g"},
      {HETINV_PARAM_G, -0.5, Inf, "g"},
      {HETINV_PARAM_G, 0.5, 0.2, "g"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_bounds(opt, bad[i].param, bad[i].lo, bad[i].hi));
    assert_message_contains(bad[i].name);
    assert_message_contains("lo < hi");
  }
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_bounds(opt, HETINV_PARAM_COUNT, 0, 1));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_bounds(opt, -1, 0, 1));
  /* Valid ones, an infinite σ bound included. */
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_A, 0, Inf));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 0, 1e-9));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_G, -0.999, 0.999));
  hetinv_optimizer_destroy(&opt);
}

/* Nothing that shapes the run can change once it has started. */
static void configuration_is_frozen_once_run(void **state) {
  const problem_t *p = *state;
  setup_t s = coarse_setup(p);
  s.iterations[0] = 1;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_DECAY, 0.5));
  assert_message_contains("HETINV_OPTIMIZER_DECAY");
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_ITERATIONS, 3));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 0, 5));
  assert_message_contains("sigma_s");
  hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, 0, 0.0, 0.0};
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_add_stage(opt, &st));
  double v = 0;
  assert_ok(hetinv_optimizer_get_param(opt, HETINV_OPTIMIZER_DECAY, &v));
  assert_true(v == 0.95);
  hetinv_optimizer_destroy(&opt);
}

static void stage_and_create_errors(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  /* An empty set cannot be optimized. */
  hetinv_measurements_t *empty = NULL;
  assert_ok(hetinv_measurements_create(p->ctx, &empty));
  static char dummy;
  opt = (hetinv_optimizer_t *)(void *)&dummy;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_create(p->ctx, empty, p->initial, &opt));
  assert_null(opt);
  hetinv_measurements_destroy(&empty);

  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  hetinv_stage_t st = {sizeof st - 1, p->coarse, 1, NULL, NULL, 0.0, 0, 0.0, 0.0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("size");
  st.size = sizeof st;
  st.iterations = -1;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("-1");
  st.iterations = 1;
  st.map = NULL;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  /* A map of another grid. */
  hetinv_medium_t *other = make_medium(p->ctx, (int32_t[]){3, 1, 3}, 1.0);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(other, SS, &map));
  st.map = map;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("grid");
  /* No stage: nothing to run, nothing to read. */
  double pi[4];
  hetinv_stop_reason_t why = 42;
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_NONE);
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_get_pi(opt, 0, pi, 1));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_save(opt, ht_path("never")));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_resume(opt, "/nonexistent"));
  size_t n = 99;
  assert_null(hetinv_optimizer_losses(opt, &n));
  assert_int_equal(n, 0);
  /* The result before any run is the initial medium. */
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  assert_true(hetinv_medium_is_committed(m));
  assert_memory_equal(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S), hetinv_medium_grid(p->initial, HETINV_PARAM_SIGMA_S),
                      4 * sizeof(double));
  hetinv_medium_destroy(&m);
  /* get_pi checks its count. */
  st.map = p->coarse;
  assert_ok(hetinv_optimizer_add_stage(opt, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_get_pi(opt, 0, pi, 4));
  assert_message_contains("4");
  hetinv_optimizer_destroy(&opt);
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&other);
}

/* ------------------------------------------------------------------------ */
/* 2. One step of every method against a hand computation (white-box). */

typedef struct hand {
  hetinv_optimizer_t opt;
  double pi[3], acc1[3], acc2[3], grad[3], scale[3], lo[3], hi[3];
} hand_t;

/* Three entries: σs-like (box [1, 10], scale 9), another (its frozen or
 * bounded twin) and a g-like one (box [-0.99, 0.99], scale 1.98). */
static void hand_init(hand_t *h, int method) {
  memset(h, 0, sizeof *h);
  hetinv_optimizer_t *o = &h->opt;
  o->param[HETINV_OPTIMIZER_METHOD] = method;
  o->param[HETINV_OPTIMIZER_DECAY] = 0.9;
  o->param[HETINV_OPTIMIZER_EPSILON] = 0.01;
  o->param[HETINV_OPTIMIZER_LEARNING_RATE] = 0.1;
  o->param[HETINV_OPTIMIZER_BETA1] = 0.5;
  o->param[HETINV_OPTIMIZER_BETA2] = 0.75;
  o->k = 3;
  o->pi = h->pi, o->acc1 = h->acc1, o->acc2 = h->acc2, o->grad = h->grad;
  o->scale = h->scale, o->lo_k = h->lo, o->hi_k = h->hi;
  o->move_lo_k = h->lo, o->move_hi_k = h->hi; /* no margin */
  const double pi[3] = {5, 5, 0.2}, scale[3] = {9, 9, 1.98}, lo[3] = {1, 1, -0.99}, hi[3] = {10, 10, 0.99};
  memcpy(h->pi, pi, sizeof pi);
  memcpy(h->scale, scale, sizeof scale);
  memcpy(h->lo, lo, sizeof lo);
  memcpy(h->hi, hi, sizeof hi);
}

/* hand_init, stepping in `coordinates`, with one cell's pair: under
 * mean-ratio coordinates entries 0 (σa-like) and 1 (σs-like), else
 * entries 0 (σs) and 2 (g). */
static int64_t hand_pair_second[3] = {2, -1, -1}, hand_pair_first[3] = {-1, -1, 0};
static int64_t mr_pair_second[3] = {1, -1, -1}, mr_pair_first[3] = {-1, 0, -1};
static void hand_init_pair(hand_t *h, int method, int coordinates) {
  hand_init(h, method);
  bool mr = coordinates == HETINV_COORDINATES_LOG_MEAN_RATIO;
  h->opt.param[HETINV_OPTIMIZER_COORDINATES] = coordinates;
  h->opt.pair_second = mr ? mr_pair_second : hand_pair_second;
  h->opt.pair_first = mr ? mr_pair_first : hand_pair_first;
}

static void adadelta_steps_match_hand_computation(void **state) {
  (void)state;
  hand_t h;
  hand_init(&h, HETINV_METHOD_ADADELTA);
  const uint8_t frozen[3] = {0, 1, 0};
  /* Step 1, gradient (2, 7, 0), entry 1 frozen:
   *   E[g²] = 0.1·2² = 0.4;  ε = (0.01·9)² = 0.0081;
   *   δ = sqrt(0 + 0.0081) / sqrt(0.4) · 2 = 0.09·2/sqrt(0.4) = 0.9/sqrt(10);
   *   E[δ²] = 0.1·δ² = 0.0081. Entry 2 (g = 0, E[g²] = 0) does not move. */
  h.grad[0] = 2, h.grad[1] = 7, h.grad[2] = 0;
  double rms = hv_method_step(&h.opt, frozen, 0.01);
  double d1 = 0.9 / sqrt(10.0);
  assert_close(h.acc1[0], 0.4, 1e-15);
  assert_close(h.acc2[0], 0.0081, 1e-15);
  assert_close(h.pi[0], 5 - d1, 1e-14);
  assert_true(h.pi[1] == 5 && h.acc1[1] == 0 && h.acc2[1] == 0); /* frozen: untouched */
  assert_true(h.pi[2] == 0.2 && h.acc1[2] == 0 && h.acc2[2] == 0);
  /* RMS over the two moving entries of δ/s: sqrt(((d1/9)² + 0)/2). */
  assert_close(rms, sqrt((d1 / 9) * (d1 / 9) / 2), 1e-15);
  /* Step 2, gradient (1, 7, -3):
   *   entry 0: E[g²] = 0.9·0.4 + 0.1·1 = 0.46; δ = sqrt(0.0081 + 0.0081)/sqrt(0.46)·1;
   *   entry 2: E[g²] = 0.1·9 = 0.9, ε = (0.0198)²; δ = 0.0198/sqrt(0.9)·(−3), a step up. */
  h.grad[0] = 1, h.grad[2] = -3;
  rms = hv_method_step(&h.opt, frozen, 0.01);
  double d2 = sqrt(0.0162 / 0.46), d2g = 0.0198 / sqrt(0.9) * -3;
  assert_close(h.acc1[0], 0.46, 1e-15);
  assert_close(h.acc2[0], 0.9 * 0.0081 + 0.1 * d2 * d2, 1e-15);
  assert_close(h.pi[0], 5 - d1 - d2, 1e-14);
  assert_close(h.pi[2], 0.2 - d2g, 1e-14);
  assert_true(h.pi[1] == 5);
  assert_close(rms, sqrt(((d2 / 9) * (d2 / 9) + (d2g / 1.98) * (d2g / 1.98)) / 2), 1e-15);
}

/* ADADELTA steps with the ε it is given: with 0.02, ε = (0.02·9)² and
 * δ = sqrt(0.0324) / sqrt(0.4) · 2. A stage's epsilon_start falls
 * linearly to the tunable over the stage's first half. */
static void adadelta_steps_with_the_stage_epsilon(void **state) {
  (void)state;
  hand_t h;
  hand_init(&h, HETINV_METHOD_ADADELTA);
  h.grad[0] = 2;
  hv_method_step(&h.opt, NULL, 0.02);
  assert_close(h.pi[0], 5 - 0.18 * 2 / sqrt(0.4), 1e-14);
  hv_stage_t st = {.iterations = 8, .epsilon_start = 0.05};
  h.opt.stages = &st;
  h.opt.stage = 0;
  const double expect[8] = {0.05, 0.04, 0.03, 0.02, 0.01, 0.01, 0.01, 0.01};
  for (int t = 0; t < 8; ++t) {
    h.opt.stage_iteration = t;
    assert_close(hv_stage_epsilon(&h.opt), expect[t], 1e-15);
  }
  st.epsilon_start = 0.0; /* the tunable throughout */
  h.opt.stage_iteration = 0;
  assert_true(hv_stage_epsilon(&h.opt) == 0.01);
  /* A settling part: the last round(0.3·8) = 2 iterations at 0.002, after
   * epsilon_start's fall. */
  st.epsilon_start = 0.05;
  st.settle_epsilon = 0.002;
  st.settle_fraction = 0.3;
  assert_int_equal(hv_stage_settle_from(&st), 6);
  const double settled[8] = {0.05, 0.04, 0.03, 0.02, 0.01, 0.01, 0.002, 0.002};
  for (int t = 0; t < 8; ++t) {
    h.opt.stage_iteration = t;
    assert_close(hv_stage_epsilon(&h.opt), settled[t], 1e-15);
  }
}

/* SGD, AdaGrad and Adam in scaled coordinates, with projection, at the
 * stage's ε relative to the tunable's. */
static void other_methods_step_as_documented(void **state) {
  (void)state;
  hand_t h;
  /* SGD: δ = rate·s²·g = 0.1·81·2 = 16.2: far below the box, projected to 1. */
  hand_init(&h, HETINV_METHOD_SGD);
  h.grad[0] = 2, h.grad[1] = -0.05, h.grad[2] = 0;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[0] == 1.0);
  assert_close(h.pi[1], 5 + 0.1 * 81 * 0.05, 1e-14);
  assert_true(h.pi[2] == 0.2);
  assert_close(rms, sqrt(((16.2 / 9) * (16.2 / 9) + (0.405 / 9) * (0.405 / 9)) / 3), 1e-14);
  /* AdaGrad: Σg² = 4, δ = 0.1·9·2/2 = 0.9; then Σg² = 4 + 1, δ = 0.1·9·1/sqrt(5). */
  hand_init(&h, HETINV_METHOD_ADAGRAD);
  h.grad[0] = 2;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 4.1, 1e-14);
  assert_true(h.pi[1] == 5 && h.pi[2] == 0.2); /* no gradient yet: no step, no NaN */
  h.grad[0] = 1;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 4.1 - 0.9 / sqrt(5.0), 1e-14);
  /* Adam (β1 = 0.5, β2 = 0.75), t = stage_iteration + 1:
   *   t = 1, g = 2: m = 1, v = 1, m̂ = 2, v̂ = 4, δ = 0.1·9·2/2 = 0.9;
   *   t = 2, g = 1: m = 1, v = 1, m̂ = 1/0.75, v̂ = 1/0.4375, δ = 0.9·(4/3)·sqrt(0.4375). */
  hand_init(&h, HETINV_METHOD_ADAM);
  h.grad[0] = 2;
  h.opt.stage_iteration = 0;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.acc1[0], 1.0, 1e-15);
  assert_close(h.acc2[0], 1.0, 1e-15);
  assert_close(h.pi[0], 4.1, 1e-14);
  h.grad[0] = 1;
  h.opt.stage_iteration = 1;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 4.1 - 0.9 * (4.0 / 3.0) * sqrt(0.4375), 1e-14);
  assert_true(h.pi[1] == 5 && h.pi[2] == 0.2);
  /* A stage's ε schedule scales their step size by its ε over the
   * tunable's (0.01): at 0.0025 SGD moves a quarter as far, Adam's first
   * step 0.9 / 4. */
  hand_init(&h, HETINV_METHOD_SGD);
  h.grad[1] = -0.05;
  hv_method_step(&h.opt, NULL, 0.0025);
  assert_close(h.pi[1], 5 + 0.25 * 0.1 * 81 * 0.05, 1e-14);
  hand_init(&h, HETINV_METHOD_ADAM);
  h.grad[0] = 2;
  h.opt.stage_iteration = 0;
  hv_method_step(&h.opt, NULL, 0.0025);
  assert_close(h.pi[0], 5 - 0.9 / 4, 1e-14);
}

/* Reduced coordinates: σs (entry 0) and g (entry 2) of one cell step as
 * (σs' = σs(1 − g), g) with the chain-ruled gradient; entry 1 stays native. */
static void reduced_coordinates_step_by_the_chain_rule(void **state) {
  (void)state;
  hand_t h;
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_REDUCED);
  h.grad[0] = 0.01, h.grad[1] = 0.001, h.grad[2] = 0.02;
  /* q = 1 − 0.2 = 0.8; ∂L/∂σs' = 0.01/0.8; ∂L/∂g|σs' = 0.02 + 0.01·5/0.8.
   * SGD: δ = rate·s²·gradient with rate 0.1, s = 9 (σs') and 1.98 (g). */
  double dr = 0.1 * 81 * (0.01 / 0.8), dg = 0.1 * 1.98 * 1.98 * (0.02 + 0.01 * 5 / 0.8);
  double g_new = 0.2 - dg, s_new = (5 * 0.8 - dr) / (1 - g_new);
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[2], g_new, 1e-14);
  assert_close(h.pi[0], s_new, 1e-14);
  assert_close(h.pi[1], 5 - 0.1 * 81 * 0.001, 1e-14);
  double d0 = (5 - s_new) / 9, d1 = 0.1 * 81 * 0.001 / 9, d2 = dg / 1.98;
  assert_close(rms, sqrt((d0 * d0 + d1 * d1 + d2 * d2) / 3), 1e-14);
  /* σs(1 − g) moved by exactly the σs' step. */
  assert_close(h.pi[0] * (1 - h.pi[2]), 5 * 0.8 - dr, 1e-14);
  /* The projection: a g step past the box stops at the bound, and σs' is
   * kept inside σs's box. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_REDUCED);
  h.grad[0] = -1, h.grad[2] = -10;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[2] == 0.99 && h.pi[0] == 10);
  /* Native coordinates ignore the pairs. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_NATIVE);
  h.grad[0] = 0.01, h.grad[2] = 0.02;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 5 - 0.1 * 81 * 0.01, 1e-14);
  assert_close(h.pi[2], 0.2 - 0.1 * 1.98 * 1.98 * 0.02, 1e-14);
}

/* Log coordinates: entries 0 and 1 (box [1, 10]) step in ln π with the
 * gradient π·g at scale ln 10; entry 2 (g's box [-0.99, 0.99], not
 * positive) stays native. SGD: δu = rate·s²·(π·g). */
static void log_coordinates_step_by_a_factor(void **state) {
  (void)state;
  hand_t h;
  hand_init(&h, HETINV_METHOD_SGD);
  h.opt.param[HETINV_OPTIMIZER_COORDINATES] = HETINV_COORDINATES_LOG;
  h.pi[1] = 1.5; /* near the floor */
  h.grad[0] = 0.01, h.grad[1] = 0.01, h.grad[2] = 0.02;
  double s = log(10.0);
  double du0 = 0.1 * s * s * (5 * 0.01), du1 = 0.1 * s * s * (1.5 * 0.01);
  double dg = 0.1 * 1.98 * 1.98 * 0.02;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 5 * exp(-du0), 1e-14);
  assert_close(h.pi[1], 1.5 * exp(-du1), 1e-14);
  assert_close(h.pi[2], 0.2 - dg, 1e-14);
  double d0 = du0 / s, d1 = du1 / s, d2 = dg / 1.98;
  assert_close(rms, sqrt((d0 * d0 + d1 * d1 + d2 * d2) / 3), 1e-14);
  /* ADADELTA's first step is sqrt(ε_k / (1 − γ))·sign(g), ε_k = (ε·s)²:
   * the same factor for every value, wherever it sits in the box. */
  hand_init(&h, HETINV_METHOD_ADADELTA);
  h.opt.param[HETINV_OPTIMIZER_COORDINATES] = HETINV_COORDINATES_LOG;
  h.pi[1] = 1.5;
  h.grad[0] = 3.0, h.grad[1] = 3.0;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0] / 5.0, exp(-0.01 * s / sqrt(0.1)), 1e-12);
  assert_close(h.pi[1] / 1.5, exp(-0.01 * s / sqrt(0.1)), 1e-12);
  /* A step past the floor stops at it. */
  hand_init(&h, HETINV_METHOD_SGD);
  h.opt.param[HETINV_OPTIMIZER_COORDINATES] = HETINV_COORDINATES_LOG;
  h.grad[0] = 10.0;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[0] == 1.0);
}

/* Mean-ratio coordinates: entries 0 (σa-like) and 1 (σs-like, both boxes
 * [1, 10]) of one cell step as p = (ln π0 + ln π1)/2, q = (ln π0 − ln π1)/2,
 * entry 2 (g, box [-0.99, 0.99]) natively. SGD at scale s = ln 10:
 * δp = rate·s²·(π0·g0 + π1·g1), δq = rate·s²·(π0·g0 − π1·g1); then
 * π0·exp(−δp − δq), π1·exp(−δp + δq). */
static void mean_ratio_coordinates_step_the_product_and_the_ratio(void **state) {
  (void)state;
  hand_t h;
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_MEAN_RATIO);
  h.pi[1] = 2.0;
  h.grad[0] = 0.01, h.grad[1] = 0.03, h.grad[2] = 0.02;
  double s = log(10.0);
  double ga = 5.0 * 0.01, gb = 2.0 * 0.03;
  double dp = 0.1 * s * s * (ga + gb), dq = 0.1 * s * s * (ga - gb), dg = 0.1 * 1.98 * 1.98 * 0.02;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 5.0 * exp(-dp - dq), 1e-14);
  assert_close(h.pi[1], 2.0 * exp(-dp + dq), 1e-14);
  assert_close(h.pi[2], 0.2 - dg, 1e-14);
  double d2 = dg / 1.98;
  assert_close(rms, sqrt(((dp / s) * (dp / s) + (dq / s) * (dq / s) + d2 * d2) / 3), 1e-14);
  /* A gradient that only trades one for the other (π0·g0 = −π1·g1) moves
   * the ratio alone: the product is unchanged. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_MEAN_RATIO);
  h.grad[0] = 0.01, h.grad[1] = -0.01;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0] * h.pi[1], 25.0, 1e-13);
  assert_true(h.pi[0] < 5.0 && h.pi[1] > 5.0);
  /* Frozen σa: σs steps alone in ln π. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_MEAN_RATIO);
  int64_t none[3] = {-1, -1, -1};
  h.opt.pair_second = none;
  h.opt.pair_first = none;
  h.grad[1] = 0.01;
  const uint8_t frozen[3] = {1, 0, 0};
  hv_method_step(&h.opt, frozen, 0.01);
  assert_true(h.pi[0] == 5.0);
  assert_close(h.pi[1], 5.0 * exp(-0.1 * s * s * 0.05), 1e-14);
}

/* Log-reduced coordinates: σs (entry 0) and g (entry 2) of one cell step
 * as (u = ln σs(1 − g), g), entry 1 (box [1, 10]) in ln π. SGD:
 * δu = rate·su²·(σs·∂L/∂σs), su = ln 10; δg = rate·1.98²·(∂L/∂g + ∂L/∂σs·σs/(1 − g)). */
static void log_reduced_coordinates_step_by_the_chain_rule(void **state) {
  (void)state;
  hand_t h;
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_REDUCED);
  h.grad[0] = 0.01, h.grad[1] = 0.001, h.grad[2] = 0.02;
  double su = log(10.0);
  double du = 0.1 * su * su * (5 * 0.01), dg = 0.1 * 1.98 * 1.98 * (0.02 + 0.01 * 5 / 0.8);
  double du1 = 0.1 * su * su * (5 * 0.001);
  double g_new = 0.2 - dg;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[2], g_new, 1e-14);
  /* σs(1 − g) moved by exactly the factor e^(-δu). */
  assert_close(h.pi[0] * (1 - h.pi[2]), 5 * 0.8 * exp(-du), 1e-14);
  assert_close(h.pi[1], 5 * exp(-du1), 1e-14);
  double d0 = du / su, d1 = du1 / su, d2 = dg / 1.98;
  assert_close(rms, sqrt((d0 * d0 + d1 * d1 + d2 * d2) / 3), 1e-14);
  /* The projection: g stops at its bound, σs at its box's top. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_REDUCED);
  h.grad[0] = -1, h.grad[2] = -10;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[2] == 0.99 && h.pi[0] == 10);
  /* A σs box that is not positive steps as in reduced coordinates. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_REDUCED);
  h.lo[0] = 0.0;
  h.grad[0] = 0.01, h.grad[2] = 0.02;
  double dr = 0.1 * 81 * (0.01 / 0.8);
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0] * (1 - h.pi[2]), 5 * 0.8 - dr, 1e-14);
}

/* ------------------------------------------------------------------------ */
/* 2. Every method lowers the loss: σs of a uniform medium from 8 toward 3. */

static void every_method_moves_sigma_s_toward_the_truth(void **state) {
  const problem_t *p = *state;
  static const struct { int method; double rate; } methods[] = {
      {HETINV_METHOD_ADADELTA, 0}, {HETINV_METHOD_SGD, 0}, {HETINV_METHOD_ADAGRAD, 0.1}, {HETINV_METHOD_ADAM, 0.05}};
  for (size_t i = 0; i < sizeof methods / sizeof methods[0]; ++i) {
    setup_t s = coarse_setup(p);
    s.method = methods[i].method;
    s.iterations[0] = 25;
    s.window = 5;
    hetinv_optimizer_t *opt = make_optimizer(p, &s);
    if (methods[i].method == HETINV_METHOD_ADADELTA) {
      assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_EPSILON, 0.05));
    } else if (methods[i].method == HETINV_METHOD_SGD) {
      /* SGD needs a rate for the loss's units: about 1/(s²·|g₀|) of the box per step. */
      double grad = 0.0;
      hetinv_medium_t *start = NULL;
      assert_ok(hetinv_medium_clone(p->initial, &start));
      assert_ok(hetinv_medium_commit(start));
      assert_ok(hetinv_estimator_loss_gradient(p->est, start, p->set, p->coarse, NULL, NULL, &grad, 1));
      hetinv_medium_destroy(&start);
      assert_true(grad > 0); /* too much scattering: the loss falls with σs */
      assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_LEARNING_RATE, 0.5 / (81 * grad)));
    } else {
      assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_LEARNING_RATE, methods[i].rate));
    }
    hetinv_stop_reason_t why = HETINV_STOP_NONE;
    assert_ok(hetinv_optimizer_run(opt, p->est, &why));
    assert_int_equal(why, HETINV_STOP_COMPLETED);
    hetinv_medium_t *m = NULL;
    assert_ok(hetinv_optimizer_result(opt, &m));
    double sigma = mean_sigma_s(m);
    size_t n = 0;
    const double *loss = hetinv_optimizer_losses(opt, &n);
    assert_int_equal(n, 25);
    double first = (loss[0] + loss[1] + loss[2]) / 3, last = (loss[22] + loss[23] + loss[24]) / 3;
    if (!(fabs(sigma - TRUTH_SIGMA_S) < 0.5 * fabs(START_SIGMA_S - TRUTH_SIGMA_S)) || !(last < first)) {
      print_error("method %d: sigma_s %g (start %g, truth %g), loss %g -> %g\n", methods[i].method, sigma,
                  START_SIGMA_S, TRUTH_SIGMA_S, first, last);
      fail();
    }
    /* σa and g were not free: untouched. */
    assert_memory_equal(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A), hetinv_medium_grid(p->initial, HETINV_PARAM_SIGMA_A),
                        4 * sizeof(double));
    assert_memory_equal(hetinv_medium_grid(m, HETINV_PARAM_G), hetinv_medium_grid(p->initial, HETINV_PARAM_G),
                        4 * sizeof(double));
    hetinv_medium_destroy(&m);
    hetinv_optimizer_destroy(&opt);
  }
}

/* ------------------------------------------------------------------------ */
/* 3. Box projection, frozen entries, masked values. */

typedef struct pi_log {
  const hetinv_optimizer_t *opt;
  int count;
  double pi[MAX_LOSSES][MAX_K], avg[MAX_LOSSES][MAX_K];
  hetinv_progress_t progress[MAX_LOSSES];
} pi_log_t;

/* Records π (last and averaged) and the progress after every iteration. */
static int log_pi(const hetinv_progress_t *progress, void *user) {
  pi_log_t *log = user;
  if (log->count >= MAX_LOSSES) return 1;
  size_t k = log->opt->k; /* white-box: the current stage's size */
  if (hetinv_optimizer_get_pi(log->opt, 0, log->pi[log->count], k) != HETINV_SUCCESS) return 1;
  if (hetinv_optimizer_get_pi(log->opt, 1, log->avg[log->count], k) != HETINV_SUCCESS) return 1;
  log->progress[log->count] = *progress;
  ++log->count;
  return 0;
}

/* Runs two stages of `method` in `coordinates` with σs's box [4, 4.5], a
 * huge rate (SGD bounces between the bounds, ADADELTA walks into one) and
 * HETINV_OPTIMIZER_BOX_MARGIN `margin`: every iterate lies in [lo, hi],
 * every average and the result in the box. *at_bound: an iterate sat on a
 * bound of the box; *outside: one lay beyond it. */
static void run_against_the_box(const problem_t *p, int method, int coordinates, double margin, double lo,
                                double hi, bool *at_bound, bool *outside) {
  setup_t s = two_stage_setup(p);
  s.method = method;
  s.iterations[0] = s.iterations[1] = 6;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 4.0, 4.5));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_LEARNING_RATE, 1e6));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_EPSILON, 1));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_COORDINATES, coordinates));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_BOX_MARGIN, margin));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 12);
  *at_bound = *outside = false;
  for (int i = 0; i < log->count; ++i) {
    size_t k = log->progress[i].stage == 0 ? 1 : 4;
    for (size_t j = 0; j < k; ++j) {
      double x = log->pi[i][j];
      assert_true(x >= lo * (1 - 1e-15) && x <= hi * (1 + 1e-15));
      assert_true(log->avg[i][j] >= 4.0 && log->avg[i][j] <= 4.5);
      *at_bound |= x == 4.0 || x == 4.5;
      *outside |= x < 4.0 || x > 4.5;
    }
  }
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  for (size_t v = 0; v < 4; ++v) {
    double x = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[v];
    assert_true(x >= 4.0 && x <= 4.5);
  }
  hetinv_medium_destroy(&m);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

static void iterates_never_leave_the_box(void **state) {
  for (int method = HETINV_METHOD_ADADELTA; method <= HETINV_METHOD_SGD; ++method) {
    bool at_bound = false, outside = false;
    run_against_the_box(*state, method, HETINV_COORDINATES_NATIVE, 0.0, 4.0, 4.5, &at_bound, &outside);
    assert_true(at_bound); /* the projection was exercised */
  }
}

/* HETINV_OPTIMIZER_BOX_MARGIN: the iterates move in the box widened by
 * the margin (natively by m·width each side, in ln π by the factor
 * (hi/lo)^m) and do leave the box; every average, the stages' hand-on
 * and the result are in the box. */
static void iterates_leave_the_box_by_its_margin(void **state) {
  for (int coordinates = HETINV_COORDINATES_NATIVE; coordinates <= HETINV_COORDINATES_LOG; coordinates += 2) {
    for (int method = HETINV_METHOD_ADADELTA; method <= HETINV_METHOD_SGD; ++method) {
      double lo = 3.75, hi = 4.75; /* natively: 4 - 0.5·0.5, 4.5 + 0.5·0.5 */
      if (coordinates == HETINV_COORDINATES_LOG) {
        lo = 4.0 / sqrt(4.5 / 4.0);
        hi = 4.5 * sqrt(4.5 / 4.0);
      }
      bool at_bound = false, outside = false;
      run_against_the_box(*state, method, coordinates, 0.5, lo, hi, &at_bound, &outside);
      assert_true(outside); /* the margin was used */
    }
  }
}

/* The range each entry moves in, white-box: σs's box [4, 4.5] widened
 * natively by 0.5 of its width and, in ln π, by the factor √(4.5/4); a
 * g box reaching past ±0.99 is never narrowed to ±0.99. */
static void the_margin_widens_each_range_within_physics(void **state) {
  const problem_t *p = *state;
  const struct { int coordinates; double lo, hi; } expect[] = {
      {HETINV_COORDINATES_NATIVE, 3.75, 4.75},
      {HETINV_COORDINATES_LOG, 4.0 / sqrt(4.5 / 4.0), 4.5 * sqrt(4.5 / 4.0)},
  };
  hetinv_param_map_t *g_map = NULL;
  assert_ok(hetinv_param_map_create_identity(p->initial, HETINV_FREE(HETINV_PARAM_G), &g_map));
  for (size_t c = 0; c < 3; ++c) {
    hetinv_optimizer_t *opt = NULL;
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 4.0, 4.5));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_G, -0.999, 0.5));
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_BOX_MARGIN, 0.5));
    if (c < 2) assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_COORDINATES, expect[c].coordinates));
    hetinv_stage_t st = {sizeof st, c < 2 ? p->identity : g_map, 1, NULL, NULL, 0.0, 0, 0.0, 0.0};
    assert_ok(hetinv_optimizer_add_stage(opt, &st));
    assert_ok(hv_optimizer_alloc_stage_arrays(opt, 4));
    for (size_t i = 0; i < 4; ++i) {
      if (c < 2) {
        assert_close(opt->move_lo_k[i], expect[c].lo, 1e-14);
        assert_close(opt->move_hi_k[i], expect[c].hi, 1e-14);
      } else { /* g natively: [-0.999 - 0.75, 0.5 + 0.75] cut to [-0.999, 0.99] */
        assert_true(opt->move_lo_k[i] == -0.999 && opt->move_hi_k[i] == 0.99);
      }
      assert_true(opt->lo_k[i] == (c < 2 ? 4.0 : -0.999));
    }
    hetinv_optimizer_destroy(&opt);
  }
  hetinv_param_map_destroy(&g_map);
}

/* Mean-ratio coordinates pair each cell's free σa and σs entries, white-
 * box (pair_cells); a σa box starting at 0 (no logs) pairs nothing. */
static void mean_ratio_pairs_each_cells_sigmas(void **state) {
  const problem_t *p = *state;
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(p->initial, HETINV_FREE_ALL, &map));
  size_t k = hetinv_param_map_size(map);
  for (int floor_zero = 0; floor_zero < 2; ++floor_zero) {
    hetinv_optimizer_t *opt = NULL;
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_A, floor_zero ? 0.0 : 0.01, 1.0));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 1.0, 10.0));
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_COORDINATES, HETINV_COORDINATES_LOG_MEAN_RATIO));
    hetinv_stage_t st = {sizeof st, map, 1, NULL, NULL, 0.0, 0, 0.0, 0.0};
    assert_ok(hetinv_optimizer_add_stage(opt, &st));
    assert_ok(hv_optimizer_alloc_stage_arrays(opt, k));
    size_t pairs = 0;
    for (size_t i = 0; i < k; ++i) {
      hetinv_param_t pi = HETINV_PARAM_G, pj = HETINV_PARAM_G;
      size_t ci = 0, cj = 0;
      assert_ok(hetinv_param_map_entry(map, i, &pi, &ci));
      int64_t j = opt->pair_second[i];
      if (j < 0) continue;
      assert_ok(hetinv_param_map_entry(map, (size_t)j, &pj, &cj));
      assert_true(pi == HETINV_PARAM_SIGMA_A && pj == HETINV_PARAM_SIGMA_S && ci == cj);
      assert_true(opt->pair_first[j] == (int64_t)i);
      ++pairs;
    }
    assert_int_equal(pairs, floor_zero ? 0 : k / 3);
    hetinv_optimizer_destroy(&opt);
  }
  hetinv_param_map_destroy(&map);
}

static void frozen_entries_never_move(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, SIGMA_HI));
  const uint8_t frozen[4] = {1, 0, 0, 1};
  hetinv_stage_t st = {sizeof st, p->identity, 6, frozen, NULL, 0.0, 0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &st));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 6);
  for (int i = 0; i < log->count; ++i) {
    assert_true(log->pi[i][0] == START_SIGMA_S && log->pi[i][3] == START_SIGMA_S);
    assert_true(log->avg[i][0] == START_SIGMA_S && log->avg[i][3] == START_SIGMA_S);
  }
  assert_true(log->pi[5][1] != START_SIGMA_S && log->pi[5][2] != START_SIGMA_S);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

/* All values left out: the loss is 0, so is the gradient, and π stays. */
static void masked_values_give_no_gradient(void **state) {
  const problem_t *p = *state;
  for (int method = 0; method < HETINV_METHOD_COUNT_; ++method) {
    hetinv_optimizer_t *opt = NULL;
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_METHOD, method));
    uint8_t *mask = calloc(p->count, 1);
    hetinv_stage_t st = {sizeof st, p->identity, 3, NULL, mask, 0.0, 0, 0.0, 0.0};
    assert_ok(hetinv_optimizer_add_stage(opt, &st));
    free(mask); /* copied */
    assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
    double pi[4], avg[4];
    assert_ok(hetinv_optimizer_get_pi(opt, 0, pi, 4));
    assert_ok(hetinv_optimizer_get_pi(opt, 1, avg, 4));
    for (int j = 0; j < 4; ++j) assert_true(pi[j] == START_SIGMA_S && avg[j] == START_SIGMA_S);
    size_t n = 0;
    const double *loss = hetinv_optimizer_losses(opt, &n);
    assert_int_equal(n, 3);
    for (size_t i = 0; i < n; ++i) assert_true(loss[i] == 0.0);
    hetinv_optimizer_destroy(&opt);
  }
}

/* ------------------------------------------------------------------------ */
/* 4. Minibatches. */

static void run_minibatch(const problem_t *p, outcome_t *o) {
  setup_t s = coarse_setup(p);
  s.minibatch = 2;
  s.iterations[0] = 6;
  reference_run(p, &s, 1, o);
}

static void minibatches_are_reproducible(void **state) {
  (void)state;
  problem_t a, b;
  problem_init(&a, 11, 2, 2, 4, false);
  problem_init(&b, 12, 2, 2, 4, false);
  outcome_t *x = calloc(3, sizeof *x);
  run_minibatch(&a, &x[0]);
  run_minibatch(&a, &x[1]);
  assert_same_outcome(&x[0], &x[1]);
  run_minibatch(&b, &x[2]);
  assert_memory_not_equal(x[0].losses, x[2].losses, 6 * sizeof(double));
  /* The minibatch loss is scaled to the whole set: comparable with a full batch. */
  setup_t s = coarse_setup(&a);
  s.iterations[0] = 1;
  outcome_t *full = calloc(1, sizeof *full);
  reference_run(&a, &s, 1, full);
  assert_true(x[0].losses[0] > 0.2 * full->losses[0] && x[0].losses[0] < 5 * full->losses[0]);
  free(full);
  /* Every minibatch of 2 out of 4 emitters is drawn without replacement, and
   * over many iterations every emitter is drawn. */
  int32_t picked[4], scratch[4], seen[4] = {0};
  for (int64_t it = 0; it < 64; ++it) {
    hv_minibatch_pick(5, it, 4, 2, picked, scratch);
    assert_true(picked[0] >= 0 && picked[0] < picked[1] && picked[1] < 4);
    ++seen[picked[0]], ++seen[picked[1]];
  }
  for (int g = 0; g < 4; ++g) assert_true(seen[g] > 8);
  free(x);
  problem_release(&a);
  problem_release(&b);
}

/* A minibatch keeps its values' clip scales: at a clip of 10⁻³ standard
 * errors every value is clipped, and with every scale 10⁹ none is, so the
 * loss is least squares' again, bit for bit. */
static void minibatches_keep_the_clip_scales(void **state) {
  (void)state;
  problem_t a;
  problem_init(&a, 11, 2, 2, 4, false);
  setup_t s = coarse_setup(&a);
  s.minibatch = 2;
  s.iterations[0] = 2;
  outcome_t *x = calloc(3, sizeof *x);
  reference_run(&a, &s, 1, &x[0]);
  assert_ok(hetinv_estimator_set_param(a.est, HETINV_ESTIMATOR_LOSS_CLIP, 1e-3));
  reference_run(&a, &s, 1, &x[1]);
  assert_true(x[1].losses[0] < 0.5 * x[0].losses[0]);
  double *scales = malloc(a.count * sizeof *scales);
  for (size_t i = 0; i < a.count; ++i) scales[i] = 1e9;
  assert_ok(hetinv_measurements_set_clip_scales(a.set, scales, scales, a.count));
  reference_run(&a, &s, 1, &x[2]);
  assert_same_outcome(&x[0], &x[2]);
  free(scales);
  free(x);
  problem_release(&a);
}

/* ------------------------------------------------------------------------ */
/* 5. Stopping rules and progress. */

typedef struct stopper {
  int64_t stop_at;
  int calls;
  hetinv_progress_t last;
} stopper_t;

static int stop_at(const hetinv_progress_t *progress, void *user) {
  stopper_t *s = user;
  ++s->calls;
  s->last = *progress;
  return progress->iteration == s->stop_at;
}

static void stages_run_their_counts_with_right_progress(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_ITERATIONS, 4));
  hetinv_stage_t a = {sizeof a, p->coarse, 3, NULL, NULL, 0.0, 0, 0.0, 0.0}, b = {sizeof b, p->identity, 0, NULL, NULL, 0.0, 0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &a));
  assert_ok(hetinv_optimizer_add_stage(opt, &b));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 7);
  size_t n = 0;
  const double *loss = hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 7);
  double elapsed = 0;
  for (int i = 0; i < 7; ++i) {
    const hetinv_progress_t *q = &log->progress[i];
    assert_int_equal(q->size, sizeof(hetinv_progress_t));
    assert_int_equal(q->stage, i < 3 ? 0 : 1);
    assert_int_equal(q->stage_count, 2);
    assert_int_equal(q->iteration, i + 1);
    assert_int_equal(q->stage_iteration, i < 3 ? i + 1 : i - 2);
    assert_int_equal(q->stage_iterations, i < 3 ? 3 : 4);
    assert_int_equal(q->total_iterations, 7);
    assert_true(q->loss == loss[i] && q->loss > 0);
    assert_true(q->step > 0 && isfinite(q->step));
    assert_true(q->elapsed >= elapsed);
    elapsed = q->elapsed;
  }
  /* The run is over: another run() does nothing more. */
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 7);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

static void iterations_default_is_100(void **state) {
  const problem_t *p = *state;
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(p->ctx, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 8));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2));
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  hetinv_stage_t st = {sizeof st, p->coarse, 0, NULL, NULL, 0.0, 0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &st));
  stopper_t s = {.stop_at = -1};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &s));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(s.calls, 100);
  assert_int_equal(s.last.stage_iterations, 100);
  assert_int_equal(s.last.total_iterations, 100);
  /* The estimator's epoch is restored. */
  double epoch = -1;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_EPOCH, &epoch));
  assert_true(epoch == 0);
  hetinv_optimizer_destroy(&opt);
  hetinv_estimator_destroy(&est);
}

static void a_plateau_ends_a_stage_early(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  /* Tolerance 1: no decrease can beat it, so each stage ends after 2·window. */
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 3));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 1));
  hetinv_stage_t a = {sizeof a, p->coarse, 50, NULL, NULL, 0.0, 0, 0.0, 0.0}, b = {sizeof b, p->identity, 50, NULL, NULL, 0.0, 0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &a));
  assert_ok(hetinv_optimizer_add_stage(opt, &b));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 12);
  assert_int_equal(log->progress[5].stage, 0);
  assert_int_equal(log->progress[6].stage, 1);
  assert_int_equal(log->progress[6].stage_iteration, 1);
  assert_int_equal(log->progress[11].total_iterations, 100); /* plateau stages count in full */
  free(log);
  hetinv_optimizer_destroy(&opt);

  /* Tolerance 0 and a loss that cannot fall (all values masked, loss 0):
   * 0 >= 0, a plateau after 2·window. */
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 2));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 0));
  uint8_t *mask = calloc(p->count, 1);
  hetinv_stage_t c = {sizeof c, p->coarse, 50, NULL, mask, 0.0, 0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &c));
  free(mask);
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 4);
  hetinv_optimizer_destroy(&opt);
}

static void a_time_budget_stops_the_run(void **state) {
  const problem_t *p = *state;
  setup_t s = coarse_setup(p);
  s.iterations[0] = 50;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  /* Any iteration takes longer than a nanosecond: one iteration, then stop. */
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_TIME_BUDGET, 1e-9));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_TIME_BUDGET);
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 1);
  /* The budget is spent: a second run stops at once. */
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_TIME_BUDGET);
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 1);
  hetinv_optimizer_destroy(&opt);
}

static void the_callback_stops_and_run_continues(void **state) {
  const problem_t *p = *state;
  setup_t s = two_stage_setup(p);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 4, &o[0]);

  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  stopper_t st = {.stop_at = 3};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_CALLBACK);
  assert_int_equal(st.calls, 3);
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 3);
  /* Stop again exactly at the stage boundary, then run to the end. */
  st.stop_at = 4;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_CALLBACK);
  assert_int_equal(st.last.stage, 0);
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(st.calls, 8);
  assert_int_equal(st.last.iteration, 8);
  /* The interrupted run is the uninterrupted one. */
  capture(opt, 4, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  free(o);
  hetinv_optimizer_destroy(&opt);
}

/* ------------------------------------------------------------------------ */
/* 6. Multi-resolution: stage 2 starts from stage 1's averaged result. */

/* A stage whose epsilon_start is the tunable runs bitwise as one without;
 * a larger one moves the run elsewhere; a caller built against the first
 * hetinv_stage_t passes its smaller size and what follows is not read; a
 * bad value is refused. */
static void a_stage_epsilon_start_changes_only_the_first_half(void **state) {
  const problem_t *p = *state;
  outcome_t *o = calloc(4, sizeof *o);
  setup_t s = coarse_setup(p);
  reference_run(p, &s, 1, &o[0]);
  s.epsilon_start[0] = 0.01; /* the tunable's default */
  reference_run(p, &s, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  s.epsilon_start[0] = 0.05;
  reference_run(p, &s, 1, &o[2]);
  assert_true(memcmp(o[0].pi, o[2].pi, sizeof o[0].pi) != 0);
  /* The first version's size: epsilon_start and average_window (0.05 and 5
   * here) are past it, unread. */
  setup_t t = coarse_setup(p);
  t.stages = 0;
  hetinv_optimizer_t *opt = make_optimizer(p, &t);
  hetinv_stage_t v1 = {HETINV_STAGE_SIZE_V1, p->coarse, 8, NULL, NULL, 0.05, 5, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &v1));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[3]);
  hetinv_optimizer_destroy(&opt);
  assert_same_outcome(&o[0], &o[3]);
  const double bad[3] = {-0.01, 1.5, (double)NAN};
  for (int i = 0; i < 3; ++i) {
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, bad[i], 0, 0.0, 0.0};
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
    assert_message_contains("epsilon_start");
    hetinv_optimizer_destroy(&opt);
  }
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, -1, 0.0, 0.0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("average_window is -1");
  hetinv_optimizer_destroy(&opt);
  free(o);
}

/* A settling part at the tunable's ε whose length is the window runs
 * bitwise as a stage without one; at a smaller ε it moves the run; with
 * the stage's window 0 its result averages the settling iterates alone; a
 * caller built against the second hetinv_stage_t passes its smaller size
 * and the settling members are not read; bad values are refused. */
static void a_stage_settles_at_its_own_epsilon(void **state) {
  const problem_t *p = *state;
  outcome_t *o = calloc(4, sizeof *o);
  setup_t s = coarse_setup(p);
  reference_run(p, &s, 1, &o[0]);
  s.settle_epsilon[0] = 0.01; /* the tunable's default */
  s.settle_fraction[0] = 3.0 / 8; /* 3 iterates: the ring's window */
  reference_run(p, &s, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  s.settle_epsilon[0] = 0.002;
  reference_run(p, &s, 1, &o[2]);
  assert_true(memcmp(o[0].pi, o[2].pi, sizeof o[0].pi) != 0);
  /* 2 settling iterates under the ring's 3: their mean, not the ring's. */
  s.settle_fraction[0] = 0.25;
  s.settle_epsilon[0] = 0.01;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[3]);
  hetinv_optimizer_destroy(&opt);
  assert_memory_equal(o[0].pi, o[3].pi, sizeof o[0].pi);
  s.stage_window[0] = 2;
  s.settle_epsilon[0] = 0.0;
  s.settle_fraction[0] = 0.0;
  reference_run(p, &s, 1, &o[1]);
  assert_memory_equal(o[1].avg, o[3].avg, sizeof o[1].avg);
  assert_true(memcmp(o[0].avg, o[3].avg, sizeof o[0].avg) != 0);
  /* The second version's size: the settling members are past it, unread. */
  setup_t t = coarse_setup(p);
  t.stages = 0;
  opt = make_optimizer(p, &t);
  hetinv_stage_t v2 = {HETINV_STAGE_SIZE_V2, p->coarse, 8, NULL, NULL, 0.0, 0, -5.0, 7.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &v2));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[1]);
  hetinv_optimizer_destroy(&opt);
  assert_same_outcome(&o[0], &o[1]);
  const struct { double epsilon, fraction; const char *named; } bad[] = {
      {-0.01, 0.5, "settle_epsilon is -0.01"}, {1.5, 0.5, "settle_epsilon is 1.5"},
      {(double)NAN, 0.5, "settle_epsilon is nan"}, {0.001, 0.0, "settle_fraction is 0"},
      {0.001, 1.0, "settle_fraction is 1"}, {0.001, (double)NAN, "settle_fraction is nan"},
      {0.0, 0.5, "settle_fraction is 0.5"}};
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, 0, bad[i].epsilon, bad[i].fraction};
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
    assert_message_contains(bad[i].named);
    hetinv_optimizer_destroy(&opt);
  }
  free(o);
}

/* A stage's own window: the next stage starts from the average of its
 * last 2 iterates under a tunable window of 3, and the run's result is the
 * last stage's window (4 here, more than the ring's 3: acts as 3). */
static void a_stage_window_sets_what_it_hands_on(void **state) {
  const problem_t *p = *state;
  setup_t s = two_stage_setup(p);
  s.iterations[0] = 6;
  s.stage_window[0] = 2;
  s.stage_window[1] = 4;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 10);
  assert_close(log->avg[5][0], (log->pi[4][0] + log->pi[5][0]) / 2, 1e-12);
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  for (int j = 0; j < 4; ++j) {
    double expect = (log->pi[7][j] + log->pi[8][j] + log->pi[9][j]) / 3;
    assert_close(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[j], expect, 1e-12);
  }
  hetinv_medium_destroy(&m);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

static void the_next_stage_starts_from_the_average(void **state) {
  const problem_t *p = *state;
  setup_t s = two_stage_setup(p);
  s.iterations[0] = 6;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 10);
  assert_int_equal(log->progress[5].stage, 0);
  assert_int_equal(log->progress[6].stage, 1);
  double avg0 = log->avg[5][0];
  /* The average of the last 3 iterates of stage 1. */
  assert_close(avg0, (log->pi[3][0] + log->pi[4][0] + log->pi[5][0]) / 3, 1e-12);
  assert_true(avg0 != log->pi[5][0]);
  /* One ADADELTA step from it: |δ| = EPSILON·s/sqrt(1 - γ) exactly, for g ≠ 0. */
  double step = 0.01 * (SIGMA_HI - SIGMA_LO) / sqrt(1 - 0.95);
  for (int j = 0; j < 4; ++j) {
    double moved = fabs(log->pi[6][j] - avg0);
    assert_true(moved == 0 || fabs(moved - step) < 1e-9);
  }
  /* The final result is stage 2's average over the 2 x 1 x 2 grid. */
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  for (int j = 0; j < 4; ++j) {
    double expect = (log->pi[7][j] + log->pi[8][j] + log->pi[9][j]) / 3;
    assert_close(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[j], expect, 1e-12);
  }
  hetinv_medium_destroy(&m);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

/* ------------------------------------------------------------------------ */
/* 7. Checkpoints: kill a run half-way, resume it, compare bitwise. */

static int kill_at(const hetinv_progress_t *progress, void *user) {
  const int64_t *at = user;
  if (progress->iteration == *at) raise(SIGKILL); /* really die: no cleanup, no final checkpoint */
  return 0;
}

/* Runs a configuration with checkpoints to `path` in a child process that
 * kills itself after iteration `at`. The child calls nothing of cmocka and
 * leaves by _exit only. */
static void run_killed_child(const problem_t *p, const setup_t *s, const char *path, int64_t at) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  assert_ok(hetinv_optimizer_set_checkpoint(opt, path));
  assert_ok(hetinv_optimizer_set_progress(opt, kill_at, &at));
  fflush(stdout);
  fflush(stderr);
  pid_t pid = fork();
  assert_true(pid >= 0);
  if (pid == 0) {
    hetinv_optimizer_run(opt, p->est, NULL);
    _exit(3); /* not reached */
  }
  int status = 0;
  assert_int_equal(waitpid(pid, &status, 0), pid);
  if (!(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)) {
    print_error("the child was not killed by SIGKILL (status %d)\n", status);
    fail();
  }
  hetinv_optimizer_destroy(&opt); /* the parent's copy, never run */
}

/* A fresh optimizer resumes `path`, whose run had `done` iterations, and
 * runs to the end. */
static void resume_and_finish(const problem_t *p, const setup_t *s, const char *path, size_t done,
                              const outcome_t *reference, outcome_t *o) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  assert_ok(hetinv_optimizer_resume(opt, path));
  size_t n = 0;
  const double *loss = hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, done);
  assert_memory_equal(loss, reference->losses, done * sizeof *loss);
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_resume(opt, path));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  capture(opt, reference->k, o);
  hetinv_optimizer_destroy(&opt);
}

/* No file but the checkpoint in the directory: every replacement was a rename. */
static void assert_only_checkpoints_left(int expected) {
  assert_int_equal(ht_tmpdir_entry_count(), expected);
  DIR *d = opendir(ht_path("."));
  assert_non_null(d);
  for (struct dirent *e; (e = readdir(d)) != NULL;) assert_null(strstr(e->d_name, ".tmp-"));
  closedir(d);
}

static void killed_runs_resume_bitwise(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-kill");
  char path[1024];
  snprintf(path, sizeof path, "%s", ht_path("run.ckpt"));
  outcome_t *o = calloc(2, sizeof *o);
  /* One stage of 8 iterations: checkpoints every 1 or 3 iterations, so the
   * resume starts at the kill (4) or before it (3). */
  static const struct { double interval; int64_t at; size_t done; } one[] = {{1, 4, 4}, {3, 4, 3}};
  setup_t s = coarse_setup(p);
  reference_run(p, &s, 1, &o[0]);
  for (size_t i = 0; i < sizeof one / sizeof one[0]; ++i) {
    s.interval = one[i].interval;
    run_killed_child(p, &s, path, one[i].at);
    resume_and_finish(p, &s, path, one[i].done, &o[0], &o[1]);
    assert_same_outcome(&o[0], &o[1]);
    assert_only_checkpoints_left(1);
  }
  /* Two stages (coarse 4, per voxel 4): the kill at the boundary and inside
   * the second stage. */
  s = two_stage_setup(p);
  reference_run(p, &s, 4, &o[0]);
  static const int64_t two[] = {4, 6};
  for (size_t i = 0; i < sizeof two / sizeof two[0]; ++i) {
    run_killed_child(p, &s, path, two[i]);
    resume_and_finish(p, &s, path, (size_t)two[i], &o[0], &o[1]);
    assert_same_outcome(&o[0], &o[1]);
  }
  /* With minibatches and Adam too. */
  s.minibatch = 1;
  s.method = HETINV_METHOD_ADAM;
  reference_run(p, &s, 4, &o[0]);
  run_killed_child(p, &s, path, 6);
  resume_and_finish(p, &s, path, 6, &o[0], &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  assert_only_checkpoints_left(1);
  free(o);
  ht_tmpdir_remove();
}

/* A checkpoint of the coarse setup stopped after 4 iterations. */
static void write_half_way(const problem_t *p, const setup_t *s, const char *path) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  stopper_t st = {.stop_at = 4};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, path));
  hetinv_optimizer_destroy(&opt);
}

/* A resume into a differently configured optimizer fails naming the
 * difference, and leaves that optimizer as it was. */
static void expect_refused(hetinv_optimizer_t *opt, const char *path, const char *names) {
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, path));
  assert_message_contains(names);
  size_t n = 99;
  assert_null(hetinv_optimizer_losses(opt, &n));
  assert_int_equal(n, 0);
}

static void resume_refuses_another_configuration(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-refuse");
  char path[1024];
  snprintf(path, sizeof path, "%s", ht_path("half.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, path);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 1, &o[0]);
  hetinv_optimizer_t *opt = NULL;

  /* Tunables, by name. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_ITERATIONS, 12));
  expect_refused(opt, path, "HETINV_OPTIMIZER_ITERATIONS");
  hetinv_optimizer_destroy(&opt);
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_DECAY, 0.9));
  expect_refused(opt, path, "HETINV_OPTIMIZER_DECAY");
  /* ...and the refused optimizer still runs from scratch like a fresh one. */
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_DECAY, 0.95));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  hetinv_optimizer_destroy(&opt);
  /* A stage's own iteration count. */
  setup_t t = s;
  t.iterations[0] = 9;
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stage 0");
  assert_message_contains("iterations 8 vs 9");
  hetinv_optimizer_destroy(&opt);
  /* A stage's own starting ε. */
  t = s;
  t.epsilon_start[0] = 0.02;
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stage 0");
  assert_message_contains("epsilon_start");
  hetinv_optimizer_destroy(&opt);
  /* Another schedule. */
  t = two_stage_setup(p);
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stages");
  hetinv_optimizer_destroy(&opt);
  /* Bounds. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 1, 11));
  expect_refused(opt, path, "bounds of sigma_s");
  hetinv_optimizer_destroy(&opt);
  /* Measured values (changed while no optimizer uses the set, then restored). */
  double *values = malloc(p->count * sizeof *values);
  memcpy(values, hetinv_measurements_values(p->set), p->count * sizeof *values);
  values[1] *= 1.01;
  assert_ok(hetinv_measurements_set_values(p->set, values, NULL, p->count));
  opt = make_optimizer(p, &s);
  expect_refused(opt, path, "measured values");
  hetinv_optimizer_destroy(&opt);
  values[1] /= 1.01;
  assert_ok(hetinv_measurements_set_values(p->set, values, NULL, p->count));
  /* The loss clip's scales; set back to 1 they hash as a set that never had any. */
  for (size_t i = 0; i < p->count; ++i) values[i] = i == 1 ? 2.0 : 1.0;
  assert_ok(hetinv_measurements_set_clip_scales(p->set, NULL, values, p->count));
  opt = make_optimizer(p, &s);
  expect_refused(opt, path, "clip scales");
  hetinv_optimizer_destroy(&opt);
  values[1] = 1.0;
  assert_ok(hetinv_measurements_set_clip_scales(p->set, values, values, p->count));
  free(values);
  /* Initial medium. */
  hetinv_medium_t *other = make_medium(p->ctx, p->dims, 7.0);
  assert_ok(hetinv_medium_commit(other));
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, other, &opt));
  assert_ok(configure(opt, &s));
  expect_refused(opt, path, "initial medium");
  hetinv_optimizer_destroy(&opt);
  hetinv_medium_destroy(&other);
  /* Seed. */
  hetinv_context_t *ctx2 = make_context(8);
  assert_ok(hetinv_optimizer_create(ctx2, p->set, p->initial, &opt));
  assert_ok(configure(opt, &s));
  expect_refused(opt, path, "seed");
  hetinv_optimizer_destroy(&opt);
  hetinv_context_destroy(&ctx2);

  /* The estimator's tunables are checked when the resumed run starts. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_resume(opt, path));
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 300));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_run(opt, p->est, &why));
  assert_message_contains("HETINV_ESTIMATOR_PHOTONS");
  assert_message_contains("300");
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 4);
  /* With the right estimator, the run continues as if never stopped. */
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 100));
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  capture(opt, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  hetinv_optimizer_destroy(&opt);
  free(o);
  ht_tmpdir_remove();
}

static uint64_t fnv1a64(const unsigned char *p, size_t n) {
  uint64_t h = UINT64_C(0xcbf29ce484222325);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * UINT64_C(0x100000001b3);
  return h;
}

static unsigned char *slurp(const char *path, size_t *len) {
  FILE *f = fopen(path, "rb");
  assert_non_null(f);
  fseek(f, 0, SEEK_END);
  long size = ftell(f);
  assert_true(size > 0);
  fseek(f, 0, SEEK_SET);
  unsigned char *data = malloc((size_t)size);
  assert_int_equal(fread(data, 1, (size_t)size, f), (size_t)size);
  fclose(f);
  *len = (size_t)size;
  return data;
}

/* A damaged file is refused as corrupt and changes nothing. */
static void expect_corrupt(hetinv_optimizer_t *opt, const char *path) {
  hetinv_result_t r = hetinv_optimizer_resume(opt, path);
  if (r != HETINV_ERROR_CORRUPT_FILE) {
    print_error("resume returned %s (%s)\n", hetinv_result_name(r), hetinv_context_last_error_message(NULL));
    fail();
  }
  assert_null(hetinv_optimizer_losses(opt, NULL));
}

static void damaged_checkpoints_are_refused(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-corrupt");
  char good[1024], bad[1024];
  snprintf(good, sizeof good, "%s", ht_path("good.ckpt"));
  snprintf(bad, sizeof bad, "%s", ht_path("bad.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, good);
  size_t len = 0;
  unsigned char *data = slurp(good, &len);
  unsigned char *copy = malloc(len + 1);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 1, &o[0]);
  hetinv_optimizer_t *opt = make_optimizer(p, &s);

  /* Truncated anywhere, or one byte too long. */
  const size_t cuts[] = {0, 1, 7, 8, 16, 23, 24, 25, 100, len / 2, len - 9, len - 8, len - 1};
  for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; ++i) {
    ht_write_file(bad, data, cuts[i]);
    expect_corrupt(opt, bad);
  }
  memcpy(copy, data, len);
  copy[len] = 0;
  ht_write_file(bad, copy, len + 1);
  expect_corrupt(opt, bad);
  /* One bit flipped: every byte of the header and the start of the
   * fingerprint, then bytes spread over the fingerprint and the state, and
   * every byte of the last value and the checksum. */
  for (size_t i = 0; i < len; i += i < 64 || i >= len - 16 ? 1 : 29) {
    memcpy(copy, data, len);
    copy[i] ^= (unsigned char)(1u << (i % 8));
    ht_write_file(bad, copy, len);
    expect_corrupt(opt, bad);
  }
  /* Another magic, even with a valid checksum. */
  memcpy(copy, data, len);
  memcpy(copy, "HVCKPT99", 8);
  uint64_t sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(bad, copy, len);
  expect_corrupt(opt, bad);
  assert_message_contains("magic");
  ht_write_file(bad, "not a checkpoint at all, just text.", 35);
  expect_corrupt(opt, bad);
  /* An intact file of a later or an earlier format version is
   * unsupported, not corrupt. */
  memcpy(copy, data, len);
  uint64_t version = 7;
  memcpy(copy + 16, &version, 8);
  sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(bad, copy, len);
  assert_result(HETINV_ERROR_UNSUPPORTED, hetinv_optimizer_resume(opt, bad));
  version = 1;
  memcpy(copy + 16, &version, 8);
  sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(bad, copy, len);
  assert_result(HETINV_ERROR_UNSUPPORTED, hetinv_optimizer_resume(opt, bad));
  assert_message_contains("format 1");
  /* Intact (checksummed) files whose content is inconsistent: a loss
   * history far larger than the file, an averaging ring fuller than its
   * window, a negative σs in the base medium. The tail of the file holds
   * ... ring (3 x 1), loss count, 4 losses, 3 grids of 4 voxels, checksum. */
  const size_t grids = len - 8 - 3 * 4 * 8, loss_count = grids - 4 * 8 - 8;
  const size_t ring_count = loss_count - 3 * 8 - 2 * 8, iteration = loss_count - 96;
  uint64_t field[3];
  memcpy(&field[0], data + iteration, 8);
  memcpy(&field[1], data + loss_count, 8);
  memcpy(&field[2], data + ring_count, 8);
  assert_true(field[0] == 4 && field[1] == 4 && field[2] == 3); /* the layout is as read here */
  const struct { size_t at[2]; uint64_t u; double d; } forged[] = {
      {{iteration, loss_count}, UINT64_C(1) << 40, 0}, /* would allocate 8 TiB */
      {{iteration, loss_count}, 5, 0},
      {{ring_count, ring_count}, 4, 0},
      {{grids + 4 * 8 + 8, grids + 4 * 8 + 8}, 0, -1.0}, /* σs of voxel 1 */
      {{grids + 2 * 4 * 8, grids + 2 * 4 * 8}, 0, 1.5},   /* g of voxel 0 */
  };
  for (size_t i = 0; i < sizeof forged / sizeof forged[0]; ++i) {
    memcpy(copy, data, len);
    for (int j = 0; j < 2; ++j) {
      if (forged[i].d != 0) {
        memcpy(copy + forged[i].at[j], &forged[i].d, 8);
      } else {
        memcpy(copy + forged[i].at[j], &forged[i].u, 8);
      }
    }
    sum = fnv1a64(copy, len - 8);
    memcpy(copy + len - 8, &sum, 8);
    ht_write_file(bad, copy, len);
    expect_corrupt(opt, bad);
  }
  /* Missing files are I/O errors. */
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_resume(opt, ht_path("missing.ckpt")));
  assert_message_contains("missing.ckpt");

  /* After all that, the optimizer runs from scratch like a fresh one... */
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  hetinv_optimizer_destroy(&opt);
  /* ...and the intact file resumes to the same end. */
  resume_and_finish(p, &s, good, 4, &o[0], &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  free(o);
  free(copy);
  free(data);
  ht_tmpdir_remove();
}

/* Forged checkpoints: intact (checksum recomputed) but holding a state
 * the configured run cannot be in. Each is refused as corrupt, naming the
 * field, before anything is used or allocated from it. */

/* Offsets of the state fields of a checkpoint of the coarse setup (k = 1,
 * window 3) stopped after 4 iterations: from the end, checksum, 3 grids of
 * 4 voxels, 4 losses, their count, the ring (3 x 1), head, count, window,
 * acc2, acc1, π, k, elapsed, iteration, stage iteration, stage. */
typedef struct layout {
  size_t stage, stage_it, it, elapsed, k, pi, acc1, acc2, window, count, head, ring, losses_n, losses, grids;
  size_t est; /* the estimator's tunables in the fingerprint */
} layout_t;

static layout_t coarse_layout(size_t len) {
  layout_t l;
  l.grids = len - 8 - 3 * 4 * 8;
  l.losses = l.grids - 4 * 8;
  l.losses_n = l.losses - 8;
  l.ring = l.losses_n - 3 * 8;
  l.head = l.ring - 8;
  l.count = l.head - 8;
  l.window = l.count - 8;
  l.acc2 = l.window - 8;
  l.acc1 = l.acc2 - 8;
  l.pi = l.acc1 - 8;
  l.k = l.pi - 8;
  l.elapsed = l.k - 8;
  l.it = l.elapsed - 8;
  l.stage_it = l.it - 8;
  l.stage = l.stage_it - 8;
  l.est = 24 + 8 * (4 + 3 * 64 + HETINV_OPTIMIZER_PARAM_COUNT_ + 2 * HETINV_PARAM_COUNT);
  return l;
}

typedef struct forgery {
  const char *what;   /* in the expected message */
  size_t *at[3];      /* up to three fields set to the value */
  bool is_double;
  uint64_t u;
  double d;
} forgery_t;

/* Writes `data` with the forgery applied and the checksum recomputed. */
static void write_forged(const char *path, const unsigned char *data, size_t len, unsigned char *copy,
                         const forgery_t *f) {
  memcpy(copy, data, len);
  for (int j = 0; j < 3 && f->at[j]; ++j) {
    if (f->is_double) {
      memcpy(copy + *f->at[j], &f->d, 8);
    } else {
      memcpy(copy + *f->at[j], &f->u, 8);
    }
  }
  uint64_t sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(path, copy, len);
}

/* Resumes a forged file into a fresh optimizer: true when it is refused as
 * corrupt with `what` in the message and the optimizer left empty. */
static bool refused_field(const problem_t *p, const setup_t *s, const char *path, const char *what) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  hetinv_result_t r = hetinv_optimizer_resume(opt, path);
  const char *m = hetinv_context_last_error_message(NULL);
  bool ok = r == HETINV_ERROR_CORRUPT_FILE && strstr(m, what) != NULL && hetinv_optimizer_losses(opt, NULL) == NULL;
  if (!ok) print_error("forged '%s': resume returned %s (%s)\n", what, hetinv_result_name(r), r ? m : "accepted");
  hetinv_optimizer_destroy(&opt);
  return ok;
}

static void forged_checkpoints_are_refused(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-forged");
  char good[1024], bad[1024];
  snprintf(good, sizeof good, "%s", ht_path("good.ckpt"));
  snprintf(bad, sizeof bad, "%s", ht_path("bad.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, good);
  size_t len = 0;
  unsigned char *data = slurp(good, &len);
  unsigned char *copy = malloc(len);
  layout_t l = coarse_layout(len);
  /* The layout is as read here: stage 0, iteration 4 of 4, k 1, window 3
   * holding 3 iterates with its head at 4 mod 3, 100 photons. */
  uint64_t u[8];
  size_t at[] = {l.stage, l.stage_it, l.it, l.k, l.window, l.count, l.head, l.losses_n};
  for (int i = 0; i < 8; ++i) memcpy(&u[i], data + at[i], 8);
  assert_true(u[0] == 0 && u[1] == 4 && u[2] == 4 && u[3] == 1 && u[4] == 3 && u[5] == 3 && u[6] == 1 && u[7] == 4);
  double photons = 0;
  memcpy(&photons, data + l.est + 8 * HETINV_ESTIMATOR_PHOTONS, 8);
  assert_true(photons == 100);
  size_t est_photons = l.est + 8 * HETINV_ESTIMATOR_PHOTONS, sigma_s1 = l.grids + 4 * 8 + 8, sigma_a1 = l.grids + 8;
  size_t ring1 = l.ring + 8, ring2 = l.ring + 16;

  const forgery_t forged[] = {
      {"the stage is 1", {&l.stage}, false, 1, 0},
      {"the stage iteration is 9; stage 0 has 8", {&l.stage_it}, false, 9, 0},
      {"the stage iteration is 9223372036854775808", {&l.stage_it}, false, UINT64_C(1) << 63, 0},
      {"the iteration is 3", {&l.it}, false, 3, 0},
      {"the iteration is 1099511627776", {&l.it, &l.losses_n}, false, UINT64_C(1) << 40, 0},
      {"bytes; a checkpoint of this run at iteration 5 (stage 0) has", {&l.stage_it, &l.it, &l.losses_n}, false, 5, 0},
      {"stage 0 has 2 entries", {&l.k}, false, 2, 0},
      {"the elapsed time is nan", {&l.elapsed}, true, 0, NaN},
      {"the elapsed time is -1", {&l.elapsed}, true, 0, -1},
      {"pi[0] is 130442; its bounds are [1, 10]", {&l.pi}, true, 0, 130442},
      {"pi[0] is 0.5", {&l.pi}, true, 0, 0.5},
      {"pi[0] is nan", {&l.pi}, true, 0, NaN},
      {"accumulator 1 of entry 0 is nan", {&l.acc1}, true, 0, NaN},
      {"accumulator 1 of entry 0 is -1", {&l.acc1}, true, 0, -1},
      {"accumulator 2 of entry 0 is inf", {&l.acc2}, true, 0, Inf},
      {"accumulator 2 of entry 0 is -1e-300", {&l.acc2}, true, 0, -1e-300},
      {"the averaging window is 4", {&l.window}, false, 4, 0},
      {"the averaging ring holds 2 iterates", {&l.count}, false, 2, 0},
      {"its head is 0", {&l.head}, false, 0, 0},
      {"its head is 4611686018427387904", {&l.head}, false, UINT64_C(1) << 62, 0},
      {"pi[0] (iterate 1 of the averaging ring) is 130442", {&ring1}, true, 0, 130442},
      {"pi[0] (iterate 2 of the averaging ring) is nan", {&ring2}, true, 0, NaN},
      {"the loss history has 5 losses", {&l.losses_n}, false, 5, 0},
      {"loss 0 is -1", {&l.losses}, true, 0, -1},
      {"loss 0 is nan", {&l.losses}, true, 0, NaN},
      {"sigma_s of voxel 1 is -1", {&sigma_s1}, true, 0, -1},
      {"sigma_s of voxel 1 is 7 in stage 0; no earlier stage frees sigma_s, and the initial medium's is 8", {&sigma_s1}, true, 0, 7},
      {"sigma_a of voxel 1 is 1e+223", {&sigma_a1}, true, 0, 1e223},
      {"HETINV_ESTIMATOR_PHOTONS is 0", {&est_photons}, true, 0, 0},
      {"HETINV_ESTIMATOR_PHOTONS is nan", {&est_photons}, true, 0, NaN},
  };
  int failures = 0;
  for (size_t i = 0; i < sizeof forged / sizeof forged[0]; ++i) {
    write_forged(bad, data, len, copy, &forged[i]);
    failures += !refused_field(p, &s, bad, forged[i].what);
  }
  /* The intact file still resumes. */
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_resume(opt, good));
  hetinv_optimizer_destroy(&opt);

  /* With a plateau window of 3, a stage iteration of 7 after 4 iterations
   * in all would make the plateau test read 2 losses before the history. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 3));
  stopper_t st = {.stop_at = 4};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, good));
  hetinv_optimizer_destroy(&opt);
  free(data);
  data = slurp(good, &len);
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 3));
  const forgery_t seven = {"the iteration is 4; at iteration 7 of stage 0 it must be in [7, 7]", {&l.stage_it}, false, 7, 0};
  write_forged(bad, data, len, copy, &seven);
  if (hetinv_optimizer_resume(opt, bad) == HETINV_SUCCESS) {
    print_error("forged '%s': accepted; running it:\n", seven.what);
    hetinv_optimizer_run(opt, p->est, NULL); /* shows the harm (under ASan) */
    ++failures;
  } else {
    assert_message_contains(seven.what);
  }
  hetinv_optimizer_destroy(&opt);

  /* In stage 1 of two (coarse, then per voxel), σs was freed by stage 0:
   * inside its bounds; σa was not: the initial medium's. */
  setup_t two = two_stage_setup(p);
  opt = make_optimizer(p, &two);
  st = (stopper_t){.stop_at = 6};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, good));
  hetinv_optimizer_destroy(&opt);
  free(data);
  data = slurp(good, &len);
  free(copy);
  copy = malloc(len); /* a larger file: 4 entries */
  size_t grids = len - 8 - 3 * 4 * 8;
  size_t two_sigma_a0 = grids, two_sigma_s2 = grids + 4 * 8 + 2 * 8;
  double v = 0;
  memcpy(&v, data + two_sigma_s2, 8);
  assert_true(v >= SIGMA_LO && v <= SIGMA_HI && v != START_SIGMA_S); /* the layout is as read here */
  const forgery_t stage1[] = {
      {"sigma_s of voxel 2 is 130442; its bounds are [1, 10]", {&two_sigma_s2}, true, 0, 130442},
      {"sigma_s of voxel 2 is 0.5; its bounds are [1, 10]", {&two_sigma_s2}, true, 0, 0.5},
      {"sigma_a of voxel 0 is 0.5 in stage 1; no earlier stage frees sigma_a", {&two_sigma_a0}, true, 0, 0.5},
  };
  for (size_t i = 0; i < sizeof stage1 / sizeof stage1[0]; ++i) {
    write_forged(bad, data, len, copy, &stage1[i]);
    failures += !refused_field(p, &two, bad, stage1[i].what);
  }
  opt = make_optimizer(p, &two);
  assert_ok(hetinv_optimizer_resume(opt, good));
  hetinv_optimizer_destroy(&opt);

  /* With σs in [1, ∞), π = ∞ is inside the bounds but not a value. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, Inf));
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  st.calls = 0;
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, good));
  hetinv_optimizer_destroy(&opt);
  free(data);
  data = slurp(good, &len);
  const forgery_t infinite = {"pi[0] is inf; its bounds are [1, inf]", {&l.pi}, true, 0, Inf};
  write_forged(bad, data, len, copy, &infinite);
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, Inf));
  hetinv_result_t r = hetinv_optimizer_resume(opt, bad);
  if (r != HETINV_ERROR_CORRUPT_FILE) {
    print_error("forged '%s': resume returned %s\n", infinite.what, hetinv_result_name(r));
    ++failures;
  } else {
    assert_message_contains(infinite.what);
  }
  hetinv_optimizer_destroy(&opt);
  free(copy);
  free(data);
  ht_tmpdir_remove();
  assert_int_equal(failures, 0);
}

/* The checkpoint at `data` rewritten in an older format: version 5 lacks
 * HETINV_OPTIMIZER_BOX_MARGIN in the fingerprint's tunables, version 4
 * also HETINV_OPTIMIZER_MULTISCALE, version 3 also
 * HETINV_OPTIMIZER_SMOOTHNESS (the last of the list each time), version 2
 * also HETINV_ESTIMATOR_LOSS_CLIP in its estimator tunables (the last of
 * its list). Returns the new length. */
static size_t older_format(const unsigned char *data, size_t len, uint64_t version, unsigned char *out) {
  layout_t l = coarse_layout(len);
  int first = version == 5 ? HETINV_OPTIMIZER_BOX_MARGIN
              : version == 4 ? HETINV_OPTIMIZER_MULTISCALE
                             : HETINV_OPTIMIZER_SMOOTHNESS; /* the first tunable it lacks */
  size_t cut[2] = {24 + 8 * (4 + 3 * 64 + (size_t)first), l.est + 8 * HETINV_ESTIMATOR_LOSS_CLIP};
  size_t bytes[2] = {8 * (size_t)(HETINV_OPTIMIZER_PARAM_COUNT_ - first), 8};
  int cuts = version == 2 ? 2 : 1;
  size_t n = 0, from = 0;
  for (int c = 0; c < cuts; ++c) {
    memcpy(out + n, data + from, cut[c] - from);
    n += cut[c] - from;
    from = cut[c] + bytes[c];
  }
  memcpy(out + n, data + from, len - from);
  n += len - from;
  memcpy(out + 16, &version, 8);
  uint64_t sum = fnv1a64(out, n - 8);
  memcpy(out + n - 8, &sum, 8);
  return n;
}

/* Checkpoints of formats 2 to 5 (before HETINV_ESTIMATOR_LOSS_CLIP,
 * HETINV_OPTIMIZER_SMOOTHNESS, HETINV_OPTIMIZER_MULTISCALE and
 * HETINV_OPTIMIZER_BOX_MARGIN: tunables fewer in the fingerprint) resume
 * as least squares without a prior, a multi-scale step or a margin and
 * finish as the uninterrupted run; under a clipped loss (formats 2), a
 * prior (2, 3), a multi-scale step (2-4) or a margin they are refused. */
static void older_format_checkpoints_resume(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-older-formats");
  char path[1024], old[1024];
  snprintf(path, sizeof path, "%s", ht_path("run.ckpt"));
  snprintf(old, sizeof old, "%s", ht_path("old.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, path);
  size_t len = 0;
  unsigned char *data = slurp(path, &len);
  unsigned char *older = malloc(len);
  assert_non_null(older);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 1, &o[0]);
  for (uint64_t version = 2; version <= 5; ++version) {
    ht_write_file(old, older, older_format(data, len, version, older));
    resume_and_finish(p, &s, old, 4, &o[0], &o[1]);
    assert_same_outcome(&o[0], &o[1]);
    hetinv_optimizer_t *opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_resume(opt, old));
    assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_LOSS_CLIP, 3.0));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_run(opt, p->est, NULL));
    assert_message_contains("HETINV_ESTIMATOR_LOSS_CLIP is 3; the checkpointed run used 0");
    assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_LOSS_CLIP, 0.0));
    hetinv_optimizer_destroy(&opt);
    opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_SMOOTHNESS, 2.0));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, old));
    assert_message_contains("HETINV_OPTIMIZER_SMOOTHNESS is 0 in the checkpoint and 2 here");
    hetinv_optimizer_destroy(&opt);
    opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MULTISCALE, 0.5));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, old));
    assert_message_contains("HETINV_OPTIMIZER_MULTISCALE is 0 in the checkpoint and 0.5 here");
    hetinv_optimizer_destroy(&opt);
    opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_BOX_MARGIN, 0.25));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, old));
    assert_message_contains("HETINV_OPTIMIZER_BOX_MARGIN is 0 in the checkpoint and 0.25 here");
    hetinv_optimizer_destroy(&opt);
  }
  free(o);
  free(older);
  free(data);
  ht_tmpdir_remove();
}

/* The base-medium check does not refuse a real run: after a coarse stage
 * that interpolates (2 x 1 x 2 cells over 3 x 1 x 3 voxels), a checkpoint of
 * the next stage resumes. */
static void interpolated_base_media_resume(void **state) {
  (void)state;
  problem_t p;
  problem_init(&p, 5, 3, 3, 2, false);
  ht_tmpdir_create("optimizer-interpolated");
  char path[1024];
  snprintf(path, sizeof path, "%s", ht_path("stage1.ckpt"));
  hetinv_param_map_t *coarse = NULL;
  assert_ok(hetinv_param_map_create_coarse(p.initial, (int32_t[]){2, 1, 2}, SS, &coarse));
  setup_t s = {.stages = 2, .maps = {coarse, p.identity}, .iterations = {3, 3}, .method = HETINV_METHOD_ADADELTA,
               .minibatch = 0, .window = 3, .interval = 1};
  hetinv_optimizer_t *opt = make_optimizer(&p, &s);
  stopper_t st = {.stop_at = 4};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p.est, NULL));
  assert_int_equal(st.last.stage, 1);
  assert_ok(hetinv_optimizer_save(opt, path));
  hetinv_optimizer_destroy(&opt);
  opt = make_optimizer(&p, &s);
  assert_ok(hetinv_optimizer_resume(opt, path));
  hetinv_optimizer_destroy(&opt);
  hetinv_param_map_destroy(&coarse);
  ht_tmpdir_remove();
  problem_release(&p);
}

/* Only regular files are read, and none larger than the configured run
 * can write. */
static void only_regular_checkpoint_files_are_read(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-notfile");
  setup_t s = coarse_setup(p);
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  /* A directory (ftell would report LLONG_MAX). */
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_resume(opt, ht_path(".")));
  assert_message_contains("not a regular file");
  /* A sparse 64 GiB file: refused from its size, before anything is
   * allocated or read. */
  char big[1024], fifo[1024];
  snprintf(big, sizeof big, "%s", ht_path("big.ckpt"));
  FILE *f = fopen(big, "wb");
  assert_non_null(f);
  assert_int_equal(ftruncate(fileno(f), (off_t)1 << 36), 0);
  fclose(f);
  assert_result(HETINV_ERROR_CORRUPT_FILE, hetinv_optimizer_resume(opt, big));
  assert_message_contains("68719476736 bytes; a checkpoint of this run has at most");
  unlink(big);
  /* A FIFO (whose open would wait for a writer). */
  snprintf(fifo, sizeof fifo, "%s", ht_path("fifo.ckpt"));
  assert_int_equal(mkfifo(fifo, 0600), 0);
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_resume(opt, fifo));
  assert_message_contains("not a regular file");
  unlink(fifo);
  assert_null(hetinv_optimizer_losses(opt, NULL));
  hetinv_optimizer_destroy(&opt);
  ht_tmpdir_remove();
}

/* ------------------------------------------------------------------------ */
/* 8. Layer-wise stages (Fig. 2(b)). */

static void layerwise_errors(void **state) {
  const problem_t *steady = *state; /* steady rows only: nothing frontlit and resolved */
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(steady->ctx, steady->set, steady->initial, &opt));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, steady->identity, 0.5, 2, 1));
  assert_message_contains("frontlit");
  hetinv_optimizer_destroy(&opt);

  problem_t p;
  problem_init(&p, 3, 3, 3, 1, true);
  assert_ok(hetinv_optimizer_create(p.ctx, p.set, p.initial, &opt));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.coarse, 1.0 / 3, 3, 1));
  assert_message_contains("one value per voxel");
  const double thickness[] = {0, -1, NaN, Inf, -Inf};
  for (size_t i = 0; i < sizeof thickness / sizeof thickness[0]; ++i) {
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.identity, thickness[i], 3, 1));
    assert_message_contains("layer_thickness");
  }
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.identity, 0.5, 0, 1));
  assert_message_contains("layers");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.identity, 0.5, 2, -1));
  assert_message_contains("iterations");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, NULL, 0.5, 2, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_layerwise_stages(NULL, p.identity, 0.5, 2, 1));
  /* A map of another grid with the same dimensions. */
  hetinv_medium_t *other = NULL;
  assert_ok(hetinv_medium_create(p.ctx, (double[]){0, 0, 0}, (double[]){2, 2, 2}, p.dims, &other));
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(other, SS, &map));
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&other);
  /* A very thin layer: every voxel lies in a deep layer (no overflow). */
  assert_ok(hetinv_optimizer_add_layerwise_stages(opt, p.identity, 1e-300, 1, 1));
  assert_int_equal(opt->stage_count, 1);
  for (size_t i = 0; i < 9; ++i) assert_true(opt->stages[0].frozen[i]);
  hetinv_optimizer_destroy(&opt);
  problem_release(&p);
}

static void layerwise_stages_free_one_layer_each(void **state) {
  (void)state;
  problem_t p;
  problem_init(&p, 3, 3, 3, 1, true); /* 3 x 1 x 3 voxels, one beam at x = 0.5 */
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p.ctx, p.set, p.initial, &opt));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, SIGMA_HI));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_AVERAGE_WINDOW, 1));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_EPSILON, 0.05));
  /* A first coarse stage, then three layers of 1/3 mm. */
  hetinv_stage_t first = {sizeof first, p.coarse, 2, NULL, NULL, 0.0, 0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &first));
  const double h = 1.0 / 3;
  assert_ok(hetinv_optimizer_add_layerwise_stages(opt, p.identity, h, 3, 4));
  assert_int_equal(opt->stage_count, 4);

  /* White-box: stage 1 + n frees the voxels of z = n and keeps the bins
   * whose window ends before sqrt(d² + (2(n+1)h)²), d the distance from the
   * beam's entry point to the pixel's centre. */
  size_t offset = 0;
  int32_t pixels = 0, bins = 0;
  assert_ok(hetinv_measurements_row_layout(p.set, 0, &offset, &pixels, &bins));
  assert_true(pixels == 3 && bins == BINS && p.count == 48);
  for (int n = 0; n < 3; ++n) {
    const hv_stage_t *st = &opt->stages[1 + n];
    assert_int_equal(st->k, 9);
    assert_int_equal(st->iterations == 0 ? st->requested : st->iterations, 4);
    for (int v = 0; v < 9; ++v) assert_int_equal(st->frozen[v] != 0, v / 3 != n);
    for (int b = 0; b < BINS; ++b) {
      for (int px = 0; px < 3; ++px) {
        double d = (px + 0.5) / 3 - p.beam_x[0], depth2 = 2 * (n + 1) * h;
        bool keep = (b + 1) * BIN_WIDTH <= sqrt(d * d + depth2 * depth2);
        assert_int_equal(st->value_mask[(size_t)b * 3 + (size_t)px] != 0, keep);
      }
    }
  }

  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p.est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 2 + 3 * 4);
  assert_int_equal(log->progress[0].stage_count, 4);
  /* Stage 0 ends with every voxel at its (coarse) average. */
  double before[9];
  for (int v = 0; v < 9; ++v) before[v] = log->avg[1][0];
  for (int n = 0; n < 3; ++n) {
    bool moved = false;
    for (int i = 0; i < 4; ++i) {
      const int row = 2 + 4 * n + i;
      assert_int_equal(log->progress[row].stage, 1 + n);
      for (int v = 0; v < 9; ++v) {
        if (v / 3 != n) {
          assert_true(log->pi[row][v] == before[v]); /* other layers never move */
        } else {
          moved |= log->pi[row][v] != before[v];
        }
      }
    }
    assert_true(moved); /* the layer's own voxels did */
    memcpy(before, log->pi[2 + 4 * n + 3], sizeof before); /* window 1: the average is the last iterate */
  }
  free(log);
  hetinv_optimizer_destroy(&opt);
  problem_release(&p);
}

/* ------------------------------------------------------------------------ */
/* 9. NULL arguments. */

static void null_arguments_are_refused(void **state) {
  const problem_t *p = *state;
  static char dummy;
  hetinv_optimizer_t *const sentinel = (hetinv_optimizer_t *)(void *)&dummy;
  hetinv_optimizer_t *opt = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(NULL, p->set, p->initial, &opt));
  assert_null(opt);
  opt = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(p->ctx, NULL, p->initial, &opt));
  assert_null(opt);
  opt = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(p->ctx, p->set, NULL, &opt));
  assert_null(opt);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(p->ctx, p->set, p->initial, NULL));

  hetinv_optimizer_destroy(NULL);
  opt = NULL;
  hetinv_optimizer_destroy(&opt);
  assert_null(opt);

  setup_t s = coarse_setup(p);
  s.iterations[0] = 1;
  opt = make_optimizer(p, &s);
  double v = 0, pi[1];
  hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, 0, 0.0, 0.0};
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_param(NULL, HETINV_OPTIMIZER_DECAY, 0.5));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_param(NULL, HETINV_OPTIMIZER_DECAY, &v));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_param(opt, HETINV_OPTIMIZER_DECAY, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_bounds(NULL, HETINV_PARAM_G, 0, 0.5));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_stage(NULL, &st));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_stage(opt, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_progress(NULL, NULL, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_checkpoint(NULL, "x"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_save(NULL, "x"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_save(opt, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_resume(NULL, "x"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_resume(opt, NULL));
  hetinv_stop_reason_t why = 42;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_run(NULL, p->est, &why));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_run(opt, NULL, &why));
  assert_int_equal(why, HETINV_STOP_NONE);
  hetinv_medium_t *m = (hetinv_medium_t *)(void *)&dummy;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_result(NULL, &m));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_result(opt, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_pi(NULL, 0, pi, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_pi(opt, 0, NULL, 1));
  size_t n = 99;
  assert_null(hetinv_optimizer_losses(NULL, &n));
  assert_int_equal(n, 0);
  assert_null(hetinv_optimizer_losses(NULL, NULL));
  /* NULL clears the callback and the checkpoint path; the run needs neither. */
  assert_ok(hetinv_optimizer_set_checkpoint(opt, "/nonexistent/dir/x.ckpt"));
  assert_ok(hetinv_optimizer_set_checkpoint(opt, NULL));
  assert_ok(hetinv_optimizer_set_progress(opt, NULL, NULL));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_get_pi(opt, 0, pi, 1));
  hetinv_optimizer_destroy(&opt);
  assert_null(opt);
}

/* A checkpoint that cannot be written fails the run with an I/O error. */
static void unwritable_checkpoints_fail_the_run(void **state) {
  const problem_t *p = *state;
  setup_t s = coarse_setup(p);
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_checkpoint(opt, "/nonexistent/dir/x.ckpt"));
  hetinv_stop_reason_t why = 42;
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_run(opt, p->est, &why));
  assert_message_contains("/nonexistent/dir/x.ckpt");
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 1);
  hetinv_optimizer_destroy(&opt);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(tunables_have_documented_defaults_and_bounds),
      cmocka_unit_test(tunables_reject_bad_values_naming_them),
      cmocka_unit_test(bounds_are_validated),
      cmocka_unit_test(configuration_is_frozen_once_run),
      cmocka_unit_test(stage_and_create_errors),
      cmocka_unit_test(adadelta_steps_match_hand_computation),
      cmocka_unit_test(adadelta_steps_with_the_stage_epsilon),
      cmocka_unit_test(other_methods_step_as_documented),
      cmocka_unit_test(reduced_coordinates_step_by_the_chain_rule),
      cmocka_unit_test(log_coordinates_step_by_a_factor),
      cmocka_unit_test(log_reduced_coordinates_step_by_the_chain_rule),
      cmocka_unit_test(mean_ratio_coordinates_step_the_product_and_the_ratio),
      cmocka_unit_test(every_method_moves_sigma_s_toward_the_truth),
      cmocka_unit_test(iterates_never_leave_the_box),
      cmocka_unit_test(frozen_entries_never_move),
      cmocka_unit_test(iterates_leave_the_box_by_its_margin),
      cmocka_unit_test(the_margin_widens_each_range_within_physics),
      cmocka_unit_test(mean_ratio_pairs_each_cells_sigmas),
      cmocka_unit_test(masked_values_give_no_gradient),
      cmocka_unit_test(minibatches_are_reproducible),
      cmocka_unit_test(minibatches_keep_the_clip_scales),
      cmocka_unit_test(stages_run_their_counts_with_right_progress),
      cmocka_unit_test(iterations_default_is_100),
      cmocka_unit_test(a_plateau_ends_a_stage_early),
      cmocka_unit_test(a_time_budget_stops_the_run),
      cmocka_unit_test(the_callback_stops_and_run_continues),
      cmocka_unit_test(the_next_stage_starts_from_the_average),
      cmocka_unit_test(a_stage_epsilon_start_changes_only_the_first_half),
      cmocka_unit_test(a_stage_settles_at_its_own_epsilon),
      cmocka_unit_test(a_stage_window_sets_what_it_hands_on),
      cmocka_unit_test(killed_runs_resume_bitwise),
      cmocka_unit_test(resume_refuses_another_configuration),
      cmocka_unit_test(damaged_checkpoints_are_refused),
      cmocka_unit_test(forged_checkpoints_are_refused),
      cmocka_unit_test(older_format_checkpoints_resume),
      cmocka_unit_test(only_regular_checkpoint_files_are_read),
      cmocka_unit_test(interpolated_base_media_resume),
      cmocka_unit_test(layerwise_errors),
      cmocka_unit_test(layerwise_stages_free_one_layer_each),
      cmocka_unit_test(null_arguments_are_refused),
      cmocka_unit_test(unwritable_checkpoints_fail_the_run),
  };
  return cmocka_run_group_tests(tests, problem_setup, problem_teardown);
}
