/* The estimator API: tunables, render validation, statistics, determinism,
 * and results that are exact whatever the random numbers. Photon counts
 * are small: these are unit tests, the physics is checked in validation/. */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "test_support.h"

#define NaN ((double)NAN)
#define Inf ((double)INFINITY)

static const double box_min[3] = {0, 0, 0};
static const double box_max[3] = {10, 10, 10};

/* Whole numbers below 2^62 (without libm). */
static bool is_integer(double x) { return x == (double)(int64_t)x; }

static hetinv_context_t *make_context(int32_t threads, uint64_t seed) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = threads;
  init.seed = seed;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  return ctx;
}

static int context_setup(void **state) {
  hetinv_context_t *ctx = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 2;
  init.seed = 42;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return -1;
  *state = ctx;
  return 0;
}

/* A heterogeneous, absorbing, index-mismatched medium (committed). */
static hetinv_medium_t *make_turbid(hetinv_context_t *ctx) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){2, 2, 2}, &m));
  assert_ok(hetinv_medium_fill(m, 0.05, 0.5, 0.3));
  assert_ok(hetinv_medium_set_voxel(m, 1, 1, 0, 0.2, 1.5, -0.2));
  assert_ok(hetinv_medium_set_ior(m, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(m));
  return m;
}

/* Every σ zero, η = η_out = 1 (committed). */
static hetinv_medium_t *make_vacuum(hetinv_context_t *ctx) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){3, 3, 3}, &m));
  assert_ok(hetinv_medium_commit(m));
  return m;
}

/* Optically thick (50 mean free paths), index-matched (committed). */
static hetinv_medium_t *make_thick(hetinv_context_t *ctx) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){1, 1, 1}, &m));
  assert_ok(hetinv_medium_fill(m, 0.05, 5.0, 0.0));
  assert_ok(hetinv_medium_commit(m));
  return m;
}

/* A scene: one pencil beam entering face Z_MIN at (4, 3) along +z, and
 *   row 0: orthographic 2 x 2 sensor over face Z_MIN looking back (-z), steady;
 *   row 1: the same sensor, box bins {5, 1e6} of width 10 (8 values, bin-major);
 *   row 2: hemispherical detector over face Z_MIN, steady;
 *   row 3: hemispherical detector over face Z_MAX, steady.
 * 14 values. */
typedef struct scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *ortho, *reflect, *transmit;
  hetinv_pathlength_t *steady, *bins;
  hetinv_measurements_t *set;
  size_t count;
} scene_t;

enum { SCENE_VALUES = 14, ROW1 = 4, ROW2 = 12, ROW3 = 13 };

static void scene_init(scene_t *s, hetinv_context_t *ctx, hetinv_medium_t *medium) {
  *s = (scene_t){.ctx = ctx, .medium = medium};
  assert_ok(hetinv_emitter_create_ideal(medium, (double[]){4, 3, -1}, (double[]){0, 0, 1}, &s->beam));
  assert_ok(hetinv_sensor_create_orthographic(medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){5, 5}, 2, 2, &s->ortho));
  assert_ok(hetinv_sensor_create_hemispherical(medium, HETINV_FACE_Z_MIN, NULL, NULL, &s->reflect));
  assert_ok(hetinv_sensor_create_hemispherical(medium, HETINV_FACE_Z_MAX, NULL, NULL, &s->transmit));
  assert_ok(hetinv_pathlength_create_steady(ctx, &s->steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 2, (double[]){5, 1e6}, 10, &s->bins));
  assert_ok(hetinv_measurements_create(ctx, &s->set));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->ortho, s->steady, NULL));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->ortho, s->bins, NULL));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->reflect, s->steady, NULL));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->transmit, s->steady, NULL));
  s->count = hetinv_measurements_value_count(s->set);
  assert_int_equal(s->count, SCENE_VALUES);
}

static void scene_release(scene_t *s) {
  hetinv_measurements_destroy(&s->set);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_pathlength_destroy(&s->bins);
  hetinv_sensor_destroy(&s->ortho);
  hetinv_sensor_destroy(&s->reflect);
  hetinv_sensor_destroy(&s->transmit);
  hetinv_emitter_destroy(&s->beam);
  hetinv_medium_destroy(&s->medium);
}

static hetinv_estimator_t *make_estimator(hetinv_context_t *ctx, double photons) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(ctx, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, photons));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 16));
  return est;
}

/* Everything one render produces. */
typedef struct output {
  double values[SCENE_VALUES], std_errors[SCENE_VALUES], ballistic[SCENE_VALUES];
  hetinv_render_stats_t stats;
} output_t;

static void render_scene(hetinv_estimator_t *est, const scene_t *s, output_t *out) {
  memset(out, 0, sizeof *out);
  assert_ok(hetinv_estimator_render(est, s->medium, s->set, out->values, out->std_errors,
                                    out->ballistic, s->count));
  out->stats.size = sizeof out->stats;
  assert_ok(hetinv_estimator_get_stats(est, &out->stats));
}

/* Bitwise equality of two renders (the wall-clock time aside). */
static bool outputs_identical(const output_t *a, const output_t *b) {
  const hetinv_render_stats_t *x = &a->stats, *y = &b->stats;
  return memcmp(a->values, b->values, sizeof a->values) == 0 &&
         memcmp(a->std_errors, b->std_errors, sizeof a->std_errors) == 0 &&
         memcmp(a->ballistic, b->ballistic, sizeof a->ballistic) == 0 &&
         x->photons == y->photons && memcmp(&x->specular, &y->specular, sizeof x->specular) == 0 &&
         memcmp(&x->absorbed, &y->absorbed, sizeof x->absorbed) == 0 &&
         memcmp(&x->absorbed_std_error, &y->absorbed_std_error, sizeof x->absorbed_std_error) == 0 &&
         memcmp(x->escaped, y->escaped, sizeof x->escaped) == 0 &&
         memcmp(x->escaped_std_error, y->escaped_std_error, sizeof x->escaped_std_error) == 0 &&
         memcmp(&x->truncated, &y->truncated, sizeof x->truncated) == 0;
}

/* ------------------------------------------------------------------------ */
/* Tunables */

static void new_estimator_has_the_documented_defaults(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  assert_non_null(est);
  double v;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_PHOTONS, &v));
  assert_true(v == 100000);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_BATCHES, &v));
  assert_true(v == 64);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_ROULETTE_WEIGHT, &v));
  assert_true(v == 1e-4);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_ROULETTE_SURVIVAL, &v));
  assert_true(v == 0.1);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, &v));
  assert_true(v == 0);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, &v));
  assert_true(v == HETINV_ESTIMATOR_DEFAULT_MAX_SCATTERING);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_STREAM, &v));
  assert_true(v == 0);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_EPOCH, &v));
  assert_true(v == 0);
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_LOSS_CLIP, &v));
  assert_true(v == 0);
  hetinv_estimator_destroy(&est);
  assert_null(est);
}

static void param_bounds_are_the_documented_ranges(void **state) {
  (void)state;
  double lo, hi;
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_PHOTONS, &lo, &hi));
  assert_true(lo == 1 && hi >= 1e9 && is_integer(hi));
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_BATCHES, &lo, &hi));
  assert_true(lo == 2 && hi == 65536);
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_ROULETTE_WEIGHT, &lo, &hi));
  assert_true(lo == 0 && hi == 1);
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_ROULETTE_SURVIVAL, &lo, &hi));
  assert_true(lo > 0 && lo <= 1e-3 && hi == 1); /* (0, 1] */
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_MIN_SCATTERING, &lo, &hi));
  assert_true(lo == 0 && hi >= 1000 && is_integer(hi));
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_MAX_SCATTERING, &lo, &hi));
  assert_true(lo == 0 && hi >= 1000 && is_integer(hi));
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_STREAM, &lo, &hi));
  assert_true(lo == 0 && hi == 65535);
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_EPOCH, &lo, &hi));
  assert_true(lo == 0 && hi == 9007199254740992.0); /* 2^53 */
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_LOSS_CLIP, &lo, &hi));
  assert_true(lo == 0 && hi == 1e6);
}

static void defaults_lie_within_the_bounds(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  for (hetinv_estimator_param_t p = 0; p < HETINV_ESTIMATOR_PARAM_COUNT_; ++p) {
    double lo, hi, v;
    assert_ok(hetinv_estimator_param_bounds(p, &lo, &hi));
    assert_ok(hetinv_estimator_get_param(est, p, &v));
    assert_true(lo <= v && v <= hi);
    /* Both bounds are themselves valid values. */
    assert_ok(hetinv_estimator_set_param(est, p, lo));
    assert_ok(hetinv_estimator_set_param(est, p, hi));
  }
  hetinv_estimator_destroy(&est);
}

static void param_bounds_accept_null_outputs(void **state) {
  (void)state;
  double hi = 0;
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_STREAM, NULL, NULL));
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_STREAM, NULL, &hi));
  assert_true(hi == 65535);
}

/* "param <p> is not an estimator parameter" for the first id past the last. */
static const char *unknown_param_message(void) {
  static char text[64];
  snprintf(text, sizeof text, "param %d is not an estimator parameter", (int)HETINV_ESTIMATOR_PARAM_COUNT_);
  return text;
}

static void param_bounds_reject_unknown_params(void **state) {
  (void)state;
  double lo, hi;
  assert_result(HETINV_ERROR_OUT_OF_RANGE,
                hetinv_estimator_param_bounds(HETINV_ESTIMATOR_PARAM_COUNT_, &lo, &hi));
  assert_message_contains(unknown_param_message());
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_estimator_param_bounds(-1, &lo, &hi));
  assert_message_contains("param -1 is not an estimator parameter");
}

static void set_param_round_trips_every_param(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  double values[HETINV_ESTIMATOR_PARAM_COUNT_];
  for (hetinv_estimator_param_t p = 0; p < HETINV_ESTIMATOR_PARAM_COUNT_; ++p) {
    assert_ok(hetinv_estimator_param_bounds(p, NULL, &values[p])); /* the upper bound, */
  }
  values[HETINV_ESTIMATOR_PHOTONS] = 12345; /* or something in between */
  values[HETINV_ESTIMATOR_BATCHES] = 17;
  values[HETINV_ESTIMATOR_ROULETTE_WEIGHT] = 0.25;
  values[HETINV_ESTIMATOR_ROULETTE_SURVIVAL] = 0.5;
  values[HETINV_ESTIMATOR_MIN_SCATTERING] = 3;
  values[HETINV_ESTIMATOR_MAX_SCATTERING] = 9;
  values[HETINV_ESTIMATOR_STREAM] = 65535;
  values[HETINV_ESTIMATOR_EPOCH] = 123456789;
  values[HETINV_ESTIMATOR_LOSS_CLIP] = 2.5;
  for (hetinv_estimator_param_t p = 0; p < HETINV_ESTIMATOR_PARAM_COUNT_; ++p) {
    assert_ok(hetinv_estimator_set_param(est, p, values[p]));
  }
  for (hetinv_estimator_param_t p = 0; p < HETINV_ESTIMATOR_PARAM_COUNT_; ++p) {
    double v;
    assert_ok(hetinv_estimator_get_param(est, p, &v));
    assert_true(v == values[p]);
  }
  hetinv_estimator_destroy(&est);
}

static void set_param_rejects_values_out_of_range(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 1));
  assert_message_contains("HETINV_ESTIMATOR_BATCHES is 1; it must be an integer in [2, 65536]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 65537));
  assert_message_contains("HETINV_ESTIMATOR_BATCHES is 65537");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 65536));
  assert_message_contains("HETINV_ESTIMATOR_STREAM is 65536; it must be an integer in [0, 65535]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, -1));
  assert_message_contains("HETINV_ESTIMATOR_STREAM is -1");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_ROULETTE_WEIGHT, 1.5));
  assert_message_contains("HETINV_ESTIMATOR_ROULETTE_WEIGHT is 1.5; it must be a number in [0, 1]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_ROULETTE_SURVIVAL, 0));
  assert_message_contains("HETINV_ESTIMATOR_ROULETTE_SURVIVAL is 0");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, -1));
  assert_message_contains("HETINV_ESTIMATOR_MIN_SCATTERING is -1");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, -2));
  assert_message_contains("HETINV_ESTIMATOR_MAX_SCATTERING is -2");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_ROULETTE_WEIGHT, NaN));
  assert_message_contains("HETINV_ESTIMATOR_ROULETTE_WEIGHT is nan");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, Inf));
  assert_message_contains("HETINV_ESTIMATOR_PHOTONS is inf");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, 1e16));
  assert_message_contains("HETINV_ESTIMATOR_EPOCH is 10000000000000000");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, -1));
  assert_message_contains("HETINV_ESTIMATOR_EPOCH is -1");
  hetinv_estimator_destroy(&est);
}

static void set_param_rejects_non_integer_values_of_integer_params(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 10.5));
  assert_message_contains("HETINV_ESTIMATOR_PHOTONS is 10.5; it must be an integer");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 8.25));
  assert_message_contains("HETINV_ESTIMATOR_BATCHES is 8.25");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 0.5));
  assert_message_contains("HETINV_ESTIMATOR_STREAM is 0.5; it must be an integer");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, 1.5));
  assert_message_contains("HETINV_ESTIMATOR_MIN_SCATTERING is 1.5");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 2.75));
  assert_message_contains("HETINV_ESTIMATOR_MAX_SCATTERING is 2.75");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, 3.5));
  assert_message_contains("HETINV_ESTIMATOR_EPOCH is 3.5; it must be an integer");
  /* Real-valued parameters take fractions. */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_ROULETTE_SURVIVAL, 0.37));
  hetinv_estimator_destroy(&est);
}

static void zero_photons_are_rejected(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 0));
  assert_message_contains("HETINV_ESTIMATOR_PHOTONS is 0");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, -5));
  assert_message_contains("HETINV_ESTIMATOR_PHOTONS is -5");
  hetinv_estimator_destroy(&est);
}

static void failed_set_param_keeps_the_old_value(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 10));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 0));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 10.5));
  double v;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_BATCHES, &v));
  assert_true(v == 10);
  hetinv_estimator_destroy(&est);
}

static void unknown_param_ids_are_rejected(void **state) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(*state, &est));
  assert_result(HETINV_ERROR_OUT_OF_RANGE,
                hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PARAM_COUNT_, 1));
  assert_message_contains(unknown_param_message());
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_estimator_set_param(est, -1, 1));
  assert_message_contains("param -1 is not an estimator parameter");
  double v = 0;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_estimator_get_param(est, 99, &v));
  assert_message_contains("param 99 is not an estimator parameter");
  hetinv_estimator_destroy(&est);
}

static void estimator_rejects_null_arguments(void **state) {
  hetinv_estimator_t *est = (hetinv_estimator_t *)ht_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_create(*state, NULL));
  assert_message_contains("'out' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_create(NULL, &est));
  assert_message_contains("'ctx' is NULL");
  assert_null(est);
  double v;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_set_param(NULL, HETINV_ESTIMATOR_PHOTONS, 1));
  assert_message_contains("'estimator' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_get_param(NULL, HETINV_ESTIMATOR_PHOTONS, &v));
  assert_ok(hetinv_estimator_create(*state, &est));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_get_param(est, HETINV_ESTIMATOR_PHOTONS, NULL));
  assert_message_contains("'value' is NULL");
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_get_stats(NULL, &stats));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_get_stats(est, NULL));
  assert_message_contains("'stats' is NULL");
  hetinv_estimator_destroy(&est);
}

static void destroy_accepts_null_and_clears_the_handle(void **state) {
  hetinv_estimator_destroy(NULL);
  hetinv_estimator_t *est = NULL;
  hetinv_estimator_destroy(&est);
  assert_ok(hetinv_estimator_create(*state, &est));
  hetinv_estimator_destroy(&est);
  assert_null(est);
  hetinv_estimator_destroy(&est);
}

/* ------------------------------------------------------------------------ */
/* Render validation */

static void render_rejects_null_arguments(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 10);
  double v[SCENE_VALUES];
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_render(NULL, s.medium, s.set, v, NULL, NULL, s.count));
  assert_message_contains("'estimator' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_render(est, NULL, s.set, v, NULL, NULL, s.count));
  assert_message_contains("'medium' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_render(est, s.medium, NULL, v, NULL, NULL, s.count));
  assert_message_contains("'set' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_estimator_render(est, s.medium, s.set, NULL, NULL, NULL, s.count));
  assert_message_contains("'values' is NULL");
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void render_rejects_an_uncommitted_medium(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_medium_t *draft = NULL;
  assert_ok(hetinv_medium_clone(s.medium, &draft));
  hetinv_estimator_t *est = make_estimator(*state, 10);
  double v[SCENE_VALUES];
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_estimator_render(est, draft, s.set, v, NULL, NULL, s.count));
  assert_message_contains("hetinv_estimator_render: the medium is not committed");
  hetinv_estimator_destroy(&est);
  hetinv_medium_destroy(&draft);
  scene_release(&s);
}

static void render_rejects_an_empty_set(void **state) {
  hetinv_medium_t *m = make_turbid(*state);
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(*state, &set));
  hetinv_estimator_t *est = make_estimator(*state, 10);
  double v[1];
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(est, m, set, v, NULL, NULL, 0));
  assert_message_contains("the measurement set has no rows");
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_medium_destroy(&m);
}

static void render_rejects_a_wrong_count(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 10);
  double v[SCENE_VALUES + 1];
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, SCENE_VALUES - 1));
  assert_message_contains("count is 13; the measurement set has 14 values");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, SCENE_VALUES + 1));
  assert_message_contains("count is 15; the measurement set has 14 values");
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void render_rejects_a_medium_with_another_box(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_medium_t *other = NULL;
  assert_ok(hetinv_medium_create(*state, box_min, (double[]){10, 12, 10}, (int32_t[]){2, 2, 2}, &other));
  assert_ok(hetinv_medium_set_ior(other, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(other));
  hetinv_estimator_t *est = make_estimator(*state, 10);
  double v[SCENE_VALUES];
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(est, other, s.set, v, NULL, NULL, s.count));
  assert_message_contains("the medium's box [0, 10] x [0, 12] x [0, 10] with eta 1.4 / 1 differs from "
                          "the box [0, 10] x [0, 10] x [0, 10] with eta 1.4 / 1 the set was made for "
                          "(its box_max[y] is 12, the set's 10)");
  hetinv_medium_destroy(&other);
  /* A difference past %g's six digits (a box read from float32) is named
   * with all its digits, not printed as two equal-looking boxes. */
  assert_ok(hetinv_medium_create(*state, box_min, (double[]){10, 10, 10.000001}, (int32_t[]){2, 2, 2}, &other));
  assert_ok(hetinv_medium_set_ior(other, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(other));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(est, other, s.set, v, NULL, NULL, s.count));
  assert_message_contains("(its box_max[z] is 10.000000999999999, the set's 10)");
  hetinv_estimator_destroy(&est);
  hetinv_medium_destroy(&other);
  scene_release(&s);
}

static void render_rejects_a_medium_with_other_indices(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_medium_t *other = NULL;
  assert_ok(hetinv_medium_create(*state, box_min, box_max, (int32_t[]){2, 2, 2}, &other));
  assert_ok(hetinv_medium_set_ior(other, 1.33, 1.0));
  assert_ok(hetinv_medium_commit(other));
  hetinv_estimator_t *est = make_estimator(*state, 10);
  double v[SCENE_VALUES];
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(est, other, s.set, v, NULL, NULL, s.count));
  assert_message_contains("with eta 1.33 / 1 differs from the box [0, 10] x [0, 10] x [0, 10] with eta 1.4 / 1 "
                          "the set was made for (its eta (inside) is 1.3300000000000001, the set's 1.3999999999999999)");
  hetinv_estimator_destroy(&est);
  hetinv_medium_destroy(&other);
  scene_release(&s);
}

static void render_accepts_another_medium_with_the_same_box_and_indices(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_medium_t *other = NULL;
  assert_ok(hetinv_medium_create(*state, box_min, box_max, (int32_t[]){5, 1, 3}, &other));
  assert_ok(hetinv_medium_fill(other, 0.1, 1.0, 0.5));
  assert_ok(hetinv_medium_set_ior(other, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(other));
  hetinv_estimator_t *est = make_estimator(*state, 50);
  double v[SCENE_VALUES];
  assert_ok(hetinv_estimator_render(est, other, s.set, v, NULL, NULL, s.count));
  hetinv_estimator_destroy(&est);
  hetinv_medium_destroy(&other);
  scene_release(&s);
}

/* A box corner at -0.0 is the same box as one at +0.0. */
static void render_accepts_a_box_that_differs_only_in_the_sign_of_zero(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_medium_t *other = NULL;
  assert_ok(hetinv_medium_create(*state, (double[]){0, -0.0, 0}, box_max, (int32_t[]){2, 2, 2}, &other));
  assert_ok(hetinv_medium_set_ior(other, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(other));
  hetinv_estimator_t *est = make_estimator(*state, 10);
  double v[SCENE_VALUES];
  assert_ok(hetinv_estimator_render(est, other, s.set, v, NULL, NULL, s.count));
  hetinv_estimator_destroy(&est);
  hetinv_medium_destroy(&other);
  scene_release(&s);
}

/* ------------------------------------------------------------------------ */
/* Statistics */

static void get_stats_before_a_render_is_invalid_state(void **state) {
  hetinv_estimator_t *est = make_estimator(*state, 10);
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_estimator_get_stats(est, &stats));
  assert_message_contains("nothing has been rendered yet");
  /* A failed render is not a render. */
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  double v[SCENE_VALUES];
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, 1));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_estimator_get_stats(est, &stats));
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void get_stats_keeps_the_last_successful_render(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 50);
  output_t o;
  render_scene(est, &s, &o);
  double v[SCENE_VALUES];
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, 3));
  hetinv_render_stats_t after = {.size = sizeof after};
  assert_ok(hetinv_estimator_get_stats(est, &after));
  assert_int_equal(after.photons, 50);
  assert_memory_equal(after.escaped, o.stats.escaped, sizeof after.escaped);
  assert_memory_equal(&after.absorbed, &o.stats.absorbed, sizeof after.absorbed);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void get_stats_rejects_a_too_small_size(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 20);
  hetinv_render_stats_t stats = {.size = sizeof(size_t)};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_get_stats(est, &stats));
  assert_message_contains("stats->size is 8; it must be at least");
  double v[SCENE_VALUES];
  assert_ok(hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, s.count));
  stats.size = 0;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_get_stats(est, &stats));
  assert_message_contains("stats->size is 0");
  /* The first published struct ended with `truncated`: one byte less is too small. */
  size_t v1 = offsetof(hetinv_render_stats_t, truncated) + sizeof(double);
  stats.size = v1 - 1;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_get_stats(est, &stats));
  /* A caller compiled against that struct gets it, and nothing after it. */
  stats.size = v1;
  stats.truncated_paths = 12345;
  assert_ok(hetinv_estimator_get_stats(est, &stats));
  assert_true(stats.size == v1 && stats.truncated_paths == 12345);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void get_stats_fills_a_larger_struct_up_to_its_own_size(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 20);
  double v[SCENE_VALUES];
  assert_ok(hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, s.count));
  /* A caller compiled against a future, longer struct. */
  struct {
    hetinv_render_stats_t v1;
    double future;
  } bigger;
  memset(&bigger, 0, sizeof bigger);
  bigger.v1.size = sizeof bigger;
  bigger.future = 12.5;
  assert_ok(hetinv_estimator_get_stats(est, &bigger.v1));
  assert_int_equal(bigger.v1.size, sizeof(hetinv_render_stats_t));
  assert_true(bigger.future == 12.5);
  assert_int_equal(bigger.v1.photons, 20);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void stats_count_the_photons_of_every_emitter(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_emitter_t *diffuse = NULL;
  assert_ok(hetinv_emitter_create_diffuse(s.medium, HETINV_FACE_Z_MIN, (double[]){6, 6}, &diffuse));
  assert_ok(hetinv_measurements_add(s.set, diffuse, s.reflect, s.steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 300);
  double v[SCENE_VALUES + 1];
  assert_ok(hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, SCENE_VALUES + 1));
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_ok(hetinv_estimator_get_stats(est, &stats));
  assert_int_equal(stats.size, sizeof stats);
  assert_int_equal(stats.photons, 600);
  assert_true(stats.seconds >= 0.0);
  /* Fractions of the emitted power: they add up to one (no truncation). */
  double sum = stats.specular + stats.absorbed + stats.truncated;
  for (int f = 0; f < 6; ++f) sum += stats.escaped[f];
  assert_true(fabs(sum - 1.0) < 0.05); /* roulette conserves power on average only */
  assert_true(stats.specular > 0.0 && stats.absorbed > 0.0 && stats.absorbed_std_error > 0.0);
  assert_true(stats.truncated == 0.0);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&s.set);
  hetinv_emitter_destroy(&diffuse);
  scene_release(&s);
}

/* ------------------------------------------------------------------------ */
/* Determinism */

static void render_is_identical_for_one_and_two_threads(void **state) {
  (void)state;
  hetinv_context_t *one = make_context(1, 2024), *two = make_context(2, 2024);
  scene_t a, b;
  scene_init(&a, one, make_turbid(one));
  scene_init(&b, two, make_turbid(two));
  hetinv_estimator_t *ea = make_estimator(one, 1000), *eb = make_estimator(two, 1000);
  output_t oa, ob;
  render_scene(ea, &a, &oa);
  render_scene(eb, &b, &ob);
  assert_true(oa.values[ROW2] > 0.0); /* something was rendered */
  assert_true(outputs_identical(&oa, &ob));
  hetinv_estimator_destroy(&ea);
  hetinv_estimator_destroy(&eb);
  scene_release(&a);
  scene_release(&b);
  hetinv_context_destroy(&one);
  hetinv_context_destroy(&two);
}

static void repeated_renders_are_identical(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 500), *fresh = make_estimator(*state, 500);
  output_t first, again, other;
  render_scene(est, &s, &first);
  render_scene(est, &s, &again);
  render_scene(fresh, &s, &other);
  assert_true(outputs_identical(&first, &again));
  assert_true(outputs_identical(&first, &other));
  hetinv_estimator_destroy(&est);
  hetinv_estimator_destroy(&fresh);
  scene_release(&s);
}

/* A medium of 40 x 40 x 24 voxels whose σa, σs and g vary voxel by voxel
 * (with `shift`): delta-tracked, and with records over 1 MB, so that a
 * second thread reads its own copy of them (committed). */
static hetinv_medium_t *make_large(hetinv_context_t *ctx, int shift) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){40, 40, 24}, &m));
  assert_ok(hetinv_medium_fill(m, 0.05, 0.5, 0.3));
  for (int32_t z = 0; z < 24; ++z) {
    for (int32_t y = 0; y < 40; ++y) {
      for (int32_t x = 0; x < 40; ++x) {
        int r = (x * 7 + y * 13 + z * 5 + shift) % 17;
        assert_ok(hetinv_medium_set_voxel(m, x, y, z, 0.02 + 0.01 * r, 0.4 + 0.05 * r, 0.05 * (r % 9)));
      }
    }
  }
  assert_ok(hetinv_medium_set_ior(m, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(m));
  return m;
}

/* An estimator keeps its passes' grid arrays (and the second thread's
 * copy) between calls: renders on media of another size, or of the same
 * size with other values, must not see what an earlier pass left. */
static void a_reused_estimator_renders_what_a_fresh_one_does(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context(2, 7);
  scene_t media[4];
  scene_init(&media[0], ctx, make_large(ctx, 0));
  scene_init(&media[1], ctx, make_turbid(ctx));
  scene_init(&media[2], ctx, make_large(ctx, 5));
  scene_init(&media[3], ctx, make_large(ctx, 0));
  hetinv_estimator_t *kept = make_estimator(ctx, 4000);
  for (int i = 0; i < 4; ++i) {
    hetinv_estimator_t *fresh = make_estimator(ctx, 4000);
    output_t a, b;
    render_scene(kept, &media[i], &a);
    render_scene(fresh, &media[i], &b);
    assert_true(a.values[ROW2] > 0.0);
    assert_true(outputs_identical(&a, &b));
    hetinv_estimator_destroy(&fresh);
  }
  hetinv_estimator_destroy(&kept);
  for (int i = 0; i < 4; ++i) scene_release(&media[i]);
  hetinv_context_destroy(&ctx);
}

static void optional_outputs_do_not_change_the_values(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 300);
  output_t full;
  render_scene(est, &s, &full);
  double v[SCENE_VALUES];
  assert_ok(hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, s.count));
  assert_memory_equal(v, full.values, sizeof v);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void stream_changes_the_result(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 300);
  output_t zero, one, zero_again;
  render_scene(est, &s, &zero);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 1));
  render_scene(est, &s, &one);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 0));
  render_scene(est, &s, &zero_again);
  assert_true(memcmp(zero.values, one.values, sizeof zero.values) != 0);
  assert_true(memcmp(&zero.stats.absorbed, &one.stats.absorbed, sizeof(double)) != 0);
  assert_true(outputs_identical(&zero, &zero_again));
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void seed_changes_the_result(void **state) {
  (void)state;
  hetinv_context_t *c1 = make_context(2, 1), *c2 = make_context(2, 2);
  scene_t a, b;
  scene_init(&a, c1, make_turbid(c1));
  scene_init(&b, c2, make_turbid(c2));
  hetinv_estimator_t *ea = make_estimator(c1, 300), *eb = make_estimator(c2, 300);
  output_t oa, ob;
  render_scene(ea, &a, &oa);
  render_scene(eb, &b, &ob);
  assert_true(memcmp(oa.values, ob.values, sizeof oa.values) != 0);
  assert_true(memcmp(&oa.stats.absorbed, &ob.stats.absorbed, sizeof(double)) != 0);
  hetinv_estimator_destroy(&ea);
  hetinv_estimator_destroy(&eb);
  scene_release(&a);
  scene_release(&b);
  hetinv_context_destroy(&c1);
  hetinv_context_destroy(&c2);
}

static void epoch_changes_the_result(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 300);
  output_t zero, one, zero_again;
  render_scene(est, &s, &zero);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, 1));
  render_scene(est, &s, &one);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, 0));
  render_scene(est, &s, &zero_again);
  assert_true(memcmp(zero.values, one.values, sizeof zero.values) != 0);
  assert_true(outputs_identical(&zero, &zero_again));
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

/* ------------------------------------------------------------------------ */
/* Exact results */

/* Row 1 holds bin 0 (pathlengths in [0, 10)) of the four pixels, then bin 1
 * (centred a million units away) of the four pixels. */
static void pathlength_bin_far_beyond_any_path_is_exactly_zero(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 500);
  output_t o;
  render_scene(est, &s, &o);
  double near = 0.0;
  for (int p = 0; p < 4; ++p) {
    near += o.values[ROW1 + p];
    assert_true(o.values[ROW1 + 4 + p] == 0.0);
    assert_true(o.std_errors[ROW1 + 4 + p] == 0.0);
    assert_true(o.ballistic[ROW1 + 4 + p] == 0.0);
    /* Neither bin can exceed the steady value of its pixel. */
    assert_true(o.values[ROW1 + p] <= o.values[p] * (1 + 1e-12));
  }
  assert_true(near > 0.0);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void orthographic_pixels_outside_the_face_get_exactly_zero(void **state) {
  hetinv_medium_t *m = make_turbid(*state);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *ortho = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){4, 3, -1}, (double[]){0, 0, 1}, &beam));
  /* Four pixels along x: [-10, -5), [-5, 0) beside the face, [0, 5), [5, 10) on it. */
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MIN, (double[]){0.2, 0, -1},
                                              (double[]){-10, 0}, (double[]){5, 10}, 4, 1, &ortho));
  assert_ok(hetinv_pathlength_create_steady(*state, &steady));
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_ok(hetinv_measurements_add(set, beam, ortho, steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 500);
  double v[4], e[4], b[4];
  assert_ok(hetinv_estimator_render(est, m, set, v, e, b, 4));
  assert_true(v[0] == 0.0 && v[1] == 0.0);
  assert_true(e[0] == 0.0 && e[1] == 0.0);
  assert_true(b[0] == 0.0 && b[1] == 0.0);
  assert_true(v[2] > 0.0 && v[3] > 0.0);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&ortho);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
}

static void vacuum_sends_all_power_out_the_opposite_face(void **state) {
  scene_t s;
  scene_init(&s, *state, make_vacuum(*state));
  hetinv_estimator_t *est = make_estimator(*state, 1000);
  output_t o;
  render_scene(est, &s, &o);
  const hetinv_render_stats_t *st = &o.stats;
  assert_int_equal(st->photons, 1000);
  assert_true(st->escaped[HETINV_FACE_Z_MAX] == 1.0);
  assert_true(st->escaped_std_error[HETINV_FACE_Z_MAX] == 0.0);
  for (int f = 0; f < 6; ++f) {
    if (f != HETINV_FACE_Z_MAX) assert_true(st->escaped[f] == 0.0);
  }
  assert_true(st->absorbed == 0.0 && st->absorbed_std_error == 0.0);
  assert_true(st->specular == 0.0);
  assert_true(st->truncated == 0.0);
  /* Transmittance 1, all of it unscattered; nothing comes back. */
  assert_true(o.values[ROW3] == 1.0);
  assert_true(o.ballistic[ROW3] == 1.0);
  assert_true(o.std_errors[ROW3] == 0.0);
  assert_true(o.values[ROW2] == 0.0 && o.ballistic[ROW2] == 0.0);
  for (int i = 0; i < ROW2; ++i) assert_true(o.values[i] == 0.0 && o.ballistic[i] == 0.0);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void pencil_beam_ballistic_pathlength_is_the_box_depth(void **state) {
  hetinv_medium_t *m = make_vacuum(*state);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *hemi = NULL;
  hetinv_pathlength_t *bins = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){2, 7, 11}, (double[]){0, 0, -1}, &beam));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &hemi));
  /* Bins [3.5, 5.5), [9, 11), [14.5, 16.5): the 10-long path falls in the middle one. */
  assert_ok(hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 3, (double[]){4.5, 10, 15.5}, 2, &bins));
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_ok(hetinv_measurements_add(set, beam, hemi, bins, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 256);
  double v[3], b[3];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, b, 3));
  assert_true(v[0] == 0.0 && v[1] == 1.0 && v[2] == 0.0);
  assert_true(b[0] == 0.0 && b[1] == 1.0 && b[2] == 0.0);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&bins);
  hetinv_sensor_destroy(&hemi);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
}

/* The ballistic channel of a pixel is power per unit area: 1 for a 1 × 1
 * pixel that the whole unscattered beam leaves through along the sensor's
 * direction; the scattered values stay 0 in vacuum. */
static void pencil_beam_ballistic_reaches_an_aligned_orthographic_pixel(void **state) {
  hetinv_medium_t *m = make_vacuum(*state);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *aligned = NULL, *tilted = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 5, -1}, (double[]){0, 0, 1}, &beam));
  /* 2 x 1 pixels of 1 x 1 on face Z_MAX: the beam leaves through pixel 1. */
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0, 0, 1},
                                              (double[]){3.5, 4.5}, (double[]){1, 1}, 2, 1, &aligned));
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0.1, 0, 1},
                                              (double[]){3.5, 4.5}, (double[]){1, 1}, 2, 1, &tilted));
  assert_ok(hetinv_pathlength_create_steady(*state, &steady));
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_ok(hetinv_measurements_add(set, beam, aligned, steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, tilted, steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 1000);
  double v[4], b[4];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, b, 4));
  assert_true(b[0] == 0.0 && b[1] == 1.0);
  assert_true(b[2] == 0.0 && b[3] == 0.0); /* a Dirac in direction misses a tilted sensor */
  for (int i = 0; i < 4; ++i) assert_true(v[i] == 0.0);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&aligned);
  hetinv_sensor_destroy(&tilted);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
}

/* The pattern is u fastest with row 0 at v = rect_min[1]: with weight only
 * in cell (1, 0), all the light crosses the vacuum straight to the part of
 * the opposite face above that cell. */
static void area_emitter_pattern_lights_only_its_weighted_cell(void **state) {
  hetinv_medium_t *m = make_vacuum(*state);
  hetinv_emitter_t *area = NULL;
  assert_ok(hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, (double[]){0, 0, 1}, (double[]){2, 1},
                                       (double[]){8, 9}, 2, 2, (double[]){0, 0.5, 0, 0}, &area));
  /* Face Z_MAX above the four cells: u in [2, 5) or [5, 8), v in [1, 5) or [5, 9). */
  hetinv_sensor_t *cell[4] = {NULL};
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 2; ++i) {
      double lo[2] = {2 + 3 * i, 1 + 4 * j}, hi[2] = {5 + 3 * i, 5 + 4 * j};
      assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, lo, hi, &cell[2 * j + i]));
    }
  }
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_pathlength_create_steady(*state, &steady));
  assert_ok(hetinv_measurements_create(*state, &set));
  for (int c = 0; c < 4; ++c) assert_ok(hetinv_measurements_add(set, area, cell[c], steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 512);
  double v[4];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, NULL, 4));
  assert_true(v[0] == 0.0);
  assert_true(v[1] == 1.0);
  assert_true(v[2] == 0.0);
  assert_true(v[3] == 0.0);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  for (int c = 0; c < 4; ++c) hetinv_sensor_destroy(&cell[c]);
  hetinv_emitter_destroy(&area);
  hetinv_medium_destroy(&m);
}

/* A combination emits the sum of its weights (values in units of power),
 * while the statistics are fractions of the emitted power. */
static void combination_emits_the_sum_of_its_weights(void **state) {
  hetinv_medium_t *m = make_vacuum(*state);
  hetinv_emitter_t *comb = NULL;
  assert_ok(hetinv_emitter_create_combination(m, 2, (double[]){2, 2, -1, 7, 7, -1},
                                              (double[]){0, 0, 1, 0, 0, 1}, (double[]){3, 1}, &comb));
  hetinv_sensor_t *exit_face = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &exit_face));
  assert_ok(hetinv_pathlength_create_steady(*state, &steady));
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_ok(hetinv_measurements_add(set, comb, exit_face, steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 1024);
  double v[1];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, NULL, 1));
  assert_true(v[0] == 4.0);
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_ok(hetinv_estimator_get_stats(est, &stats));
  if (stats.escaped[HETINV_FACE_Z_MAX] != 1.0) {
    print_error("stats.escaped[HETINV_FACE_Z_MAX] is %g; as a fraction of the emitted power "
                "it must be 1\n", stats.escaped[HETINV_FACE_Z_MAX]);
  }
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&exit_face);
  hetinv_emitter_destroy(&comb);
  hetinv_medium_destroy(&m);
  assert_true(stats.escaped[HETINV_FACE_Z_MAX] == 1.0);
}

/* A whole-face detector includes the face's edges: a beam along the box's
 * diagonal plane leaves exactly through the edge x = 10, z = 10, which
 * belongs to faces X_MAX and Z_MAX; one of the two detectors must see it. */
static void whole_face_detectors_count_light_leaving_through_an_edge(void **state) {
  hetinv_medium_t *m = make_vacuum(*state);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *top = NULL, *side = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){-1, 5, -1}, (double[]){1, 0, 1}, &beam));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &top));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_X_MAX, NULL, NULL, &side));
  assert_ok(hetinv_pathlength_create_steady(*state, &steady));
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_ok(hetinv_measurements_add(set, beam, top, steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, side, steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 64);
  double v[2];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, NULL, 2));
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_ok(hetinv_estimator_get_stats(est, &stats));
  double escaped = stats.escaped[HETINV_FACE_Z_MAX] + stats.escaped[HETINV_FACE_X_MAX];
  if (v[0] + v[1] != 1.0) {
    print_error("the Z_MAX and X_MAX detectors see %g and %g; escaped through them: %g and %g\n",
                v[0], v[1], stats.escaped[HETINV_FACE_Z_MAX], stats.escaped[HETINV_FACE_X_MAX]);
  }
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&top);
  hetinv_sensor_destroy(&side);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  assert_true(escaped == 1.0);
  assert_true(v[0] + v[1] == 1.0);
}

/* W_τ = exp(-(τ - c)² / (2 w²)) with peak 1, at the 10-long ballistic path. */
static void gaussian_window_weighs_the_ballistic_path(void **state) {
  hetinv_medium_t *m = make_vacuum(*state);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *hemi = NULL;
  hetinv_pathlength_t *bins = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 5, -1}, (double[]){0, 0, 1}, &beam));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &hemi));
  assert_ok(hetinv_pathlength_create_bins(*state, HETINV_WINDOW_GAUSSIAN, 3, (double[]){11, 10, 18.5}, 1,
                                          &bins));
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_ok(hetinv_measurements_add(set, beam, hemi, bins, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 256);
  double v[3];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, NULL, 3));
  assert_true(fabs(v[0] - 0.60653065971263342) < 1e-12); /* exp(-1/2) */
  assert_true(fabs(v[1] - 1.0) < 1e-12);
  assert_true(v[2] >= 0.0 && v[2] < 1e-15); /* exp(-36.125) */
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&bins);
  hetinv_sensor_destroy(&hemi);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
}

/* Rows that share an emitter are rendered from the same photons: a box bin
 * wider than any path repeats the steady value bit for bit, and so does a
 * repeated row. */
static void rows_of_one_emitter_share_its_photons(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_pathlength_t *all = NULL;
  assert_ok(hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 1, (double[]){0}, 1e9, &all));
  assert_ok(hetinv_measurements_add(s.set, s.beam, s.reflect, all, NULL));
  assert_ok(hetinv_measurements_add(s.set, s.beam, s.reflect, s.steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 400);
  double v[SCENE_VALUES + 2];
  assert_ok(hetinv_estimator_render(est, s.medium, s.set, v, NULL, NULL, SCENE_VALUES + 2));
  assert_true(v[ROW2] > 0.0);
  assert_memory_equal(&v[SCENE_VALUES], &v[ROW2], sizeof(double));
  assert_memory_equal(&v[SCENE_VALUES + 1], &v[ROW2], sizeof(double));
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&s.set);
  hetinv_pathlength_destroy(&all);
  scene_release(&s);
}

/* Photon i of the set's e-th emitter has its own random stream, so the rows
 * of the first emitter come out the same whether or not rows of a second
 * emitter sit between them. */
static void rows_of_one_emitter_do_not_depend_on_other_emitters(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_emitter_t *other = NULL;
  assert_ok(hetinv_emitter_create_diffuse(s.medium, HETINV_FACE_Z_MAX, (double[]){2, 2}, &other));
  hetinv_measurements_t *mixed = NULL;
  assert_ok(hetinv_measurements_create(*state, &mixed));
  assert_ok(hetinv_measurements_add(mixed, s.beam, s.reflect, s.steady, NULL));
  assert_ok(hetinv_measurements_add(mixed, other, s.ortho, s.bins, NULL));
  assert_ok(hetinv_measurements_add(mixed, s.beam, s.ortho, s.steady, NULL));
  assert_ok(hetinv_measurements_add(mixed, other, s.reflect, s.steady, NULL));
  assert_ok(hetinv_measurements_add(mixed, s.beam, s.transmit, s.steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 300);
  output_t alone;
  render_scene(est, &s, &alone);
  double v[15], e[15];
  assert_ok(hetinv_estimator_render(est, s.medium, mixed, v, e, NULL, 15));
  assert_memory_equal(&v[0], &alone.values[ROW2], sizeof(double));
  assert_memory_equal(&v[9], &alone.values[0], 4 * sizeof(double));
  assert_memory_equal(&e[9], &alone.std_errors[0], 4 * sizeof(double));
  assert_memory_equal(&v[14], &alone.values[ROW3], sizeof(double));
  assert_true(v[13] > 0.0);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&mixed);
  hetinv_emitter_destroy(&other);
  scene_release(&s);
}

static void diffuse_source_light_leaves_through_the_other_faces(void **state) {
  hetinv_medium_t *m = make_vacuum(*state);
  hetinv_emitter_t *diffuse = NULL;
  hetinv_sensor_t *back = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MIN, (double[]){5, 5}, &diffuse));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &back));
  assert_ok(hetinv_pathlength_create_steady(*state, &steady));
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_ok(hetinv_measurements_add(set, diffuse, back, steady, NULL));
  hetinv_estimator_t *est = make_estimator(*state, 500);
  double v[1];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, NULL, 1));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  assert_true(v[0] == 0.0);
  assert_true(st.escaped[HETINV_FACE_Z_MIN] == 0.0);
  assert_true(st.absorbed == 0.0 && st.specular == 0.0 && st.truncated == 0.0);
  double sum = 0.0;
  for (int f = 0; f < 6; ++f) sum += st.escaped[f];
  assert_true(fabs(sum - 1.0) < 1e-12);
  assert_true(st.escaped[HETINV_FACE_Z_MAX] > 0.0 && st.escaped[HETINV_FACE_X_MIN] > 0.0);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&back);
  hetinv_emitter_destroy(&diffuse);
  hetinv_medium_destroy(&m);
}

static void max_scattering_truncates_photons_in_a_thick_medium(void **state) {
  scene_t s;
  scene_init(&s, *state, make_thick(*state));
  hetinv_estimator_t *est = make_estimator(*state, 400);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 1));
  output_t o;
  render_scene(est, &s, &o);
  const hetinv_render_stats_t *st = &o.stats;
  assert_true(st->truncated > 0.5);
  /* Through 50 mean free paths nothing is transmitted. */
  assert_true(st->escaped[HETINV_FACE_Z_MAX] == 0.0);
  assert_true(o.values[ROW3] == 0.0);
  /* No roulette at weights near 1: the fractions add up to one. */
  double sum = st->specular + st->absorbed + st->truncated;
  for (int f = 0; f < 6; ++f) sum += st->escaped[f];
  assert_true(fabs(sum - 1.0) < 1e-12);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

/* Photons stop after their first scattering, so asking for light scattered
 * at least twice gives exactly nothing, while without the limit it does. */
static void max_scattering_one_leaves_nothing_scattered_twice(void **state) {
  scene_t s;
  scene_init(&s, *state, make_thick(*state));
  hetinv_estimator_t *est = make_estimator(*state, 200);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, 2));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 1));
  output_t limited;
  render_scene(est, &s, &limited);
  for (int i = 0; i < SCENE_VALUES; ++i) {
    assert_true(limited.values[i] == 0.0);
    assert_true(limited.ballistic[i] == 0.0);
  }
  assert_true(limited.stats.escaped[HETINV_FACE_Z_MIN] > 0.0); /* single scattering did leave */
  assert_true(limited.stats.truncated > 0.0);
  /* Control: the same photons without the limit. */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 0));
  output_t free_;
  render_scene(est, &s, &free_);
  assert_true(free_.values[0] + free_.values[1] + free_.values[2] + free_.values[3] > 0.0);
  assert_true(free_.values[ROW2] > 0.0);
  assert_true(free_.stats.truncated == 0.0);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

/* With MIN = MAX = 1 a hemispherical detector on the entry face sees only
 * light that left after exactly one scattering; with MAX = 1 alone it also
 * sees unscattered light, of which an index-matched entry face gets none. */
static void single_scattering_equals_scattering_at_most_once_on_the_entry_face(void **state) {
  scene_t s;
  scene_init(&s, *state, make_thick(*state));
  hetinv_estimator_t *est = make_estimator(*state, 400);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 1));
  output_t at_most_once, exactly_once;
  render_scene(est, &s, &at_most_once);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, 1));
  render_scene(est, &s, &exactly_once);
  assert_true(exactly_once.values[ROW2] > 0.0);
  assert_true(exactly_once.values[ROW2] == at_most_once.values[ROW2]);
  assert_true(exactly_once.ballistic[ROW2] == 0.0);
  /* Every photon that left through the entry face was counted. */
  assert_true(exactly_once.values[ROW2] == exactly_once.stats.escaped[HETINV_FACE_Z_MIN]);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void single_photon_render_has_zero_standard_errors(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 1);
  output_t o;
  render_scene(est, &s, &o);
  assert_int_equal(o.stats.photons, 1);
  for (int i = 0; i < SCENE_VALUES; ++i) {
    assert_true(isfinite(o.values[i]));
    assert_true(o.std_errors[i] == 0.0);
  }
  assert_true(o.stats.absorbed_std_error == 0.0);
  for (int f = 0; f < 6; ++f) assert_true(o.stats.escaped_std_error[f] == 0.0);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

static void values_and_errors_are_finite_and_non_negative(void **state) {
  scene_t s;
  scene_init(&s, *state, make_turbid(*state));
  hetinv_estimator_t *est = make_estimator(*state, 500);
  output_t o;
  render_scene(est, &s, &o);
  for (int i = 0; i < SCENE_VALUES; ++i) {
    assert_true(isfinite(o.values[i]) && o.values[i] >= 0.0);
    assert_true(isfinite(o.std_errors[i]) && o.std_errors[i] >= 0.0);
    assert_true(isfinite(o.ballistic[i]) && o.ballistic[i] >= 0.0);
  }
  /* Reflectance and transmittance are fractions of the emitted power. */
  assert_true(o.values[ROW2] > 0.0 && o.values[ROW2] < 1.0);
  assert_true(o.values[ROW3] > 0.0 && o.values[ROW3] < 1.0);
  assert_true(o.std_errors[ROW2] > 0.0);
  hetinv_estimator_destroy(&est);
  scene_release(&s);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(new_estimator_has_the_documented_defaults),
      cmocka_unit_test(param_bounds_are_the_documented_ranges),
      cmocka_unit_test(defaults_lie_within_the_bounds),
      cmocka_unit_test(param_bounds_accept_null_outputs),
      cmocka_unit_test(param_bounds_reject_unknown_params),
      cmocka_unit_test(set_param_round_trips_every_param),
      cmocka_unit_test(set_param_rejects_values_out_of_range),
      cmocka_unit_test(set_param_rejects_non_integer_values_of_integer_params),
      cmocka_unit_test(zero_photons_are_rejected),
      cmocka_unit_test(failed_set_param_keeps_the_old_value),
      cmocka_unit_test(unknown_param_ids_are_rejected),
      cmocka_unit_test(estimator_rejects_null_arguments),
      cmocka_unit_test(destroy_accepts_null_and_clears_the_handle),
      cmocka_unit_test(render_rejects_null_arguments),
      cmocka_unit_test(render_rejects_an_uncommitted_medium),
      cmocka_unit_test(render_rejects_an_empty_set),
      cmocka_unit_test(render_rejects_a_wrong_count),
      cmocka_unit_test(render_rejects_a_medium_with_another_box),
      cmocka_unit_test(render_rejects_a_medium_with_other_indices),
      cmocka_unit_test(render_accepts_another_medium_with_the_same_box_and_indices),
      cmocka_unit_test(render_accepts_a_box_that_differs_only_in_the_sign_of_zero),
      cmocka_unit_test(get_stats_before_a_render_is_invalid_state),
      cmocka_unit_test(get_stats_keeps_the_last_successful_render),
      cmocka_unit_test(get_stats_rejects_a_too_small_size),
      cmocka_unit_test(get_stats_fills_a_larger_struct_up_to_its_own_size),
      cmocka_unit_test(stats_count_the_photons_of_every_emitter),
      cmocka_unit_test(render_is_identical_for_one_and_two_threads),
      cmocka_unit_test(repeated_renders_are_identical),
      cmocka_unit_test(a_reused_estimator_renders_what_a_fresh_one_does),
      cmocka_unit_test(optional_outputs_do_not_change_the_values),
      cmocka_unit_test(stream_changes_the_result),
      cmocka_unit_test(seed_changes_the_result),
      cmocka_unit_test(epoch_changes_the_result),
      cmocka_unit_test(pathlength_bin_far_beyond_any_path_is_exactly_zero),
      cmocka_unit_test(orthographic_pixels_outside_the_face_get_exactly_zero),
      cmocka_unit_test(vacuum_sends_all_power_out_the_opposite_face),
      cmocka_unit_test(pencil_beam_ballistic_pathlength_is_the_box_depth),
      cmocka_unit_test(pencil_beam_ballistic_reaches_an_aligned_orthographic_pixel),
      cmocka_unit_test(area_emitter_pattern_lights_only_its_weighted_cell),
      cmocka_unit_test(combination_emits_the_sum_of_its_weights),
      cmocka_unit_test(whole_face_detectors_count_light_leaving_through_an_edge),
      cmocka_unit_test(gaussian_window_weighs_the_ballistic_path),
      cmocka_unit_test(rows_of_one_emitter_share_its_photons),
      cmocka_unit_test(rows_of_one_emitter_do_not_depend_on_other_emitters),
      cmocka_unit_test(diffuse_source_light_leaves_through_the_other_faces),
      cmocka_unit_test(max_scattering_truncates_photons_in_a_thick_medium),
      cmocka_unit_test(max_scattering_one_leaves_nothing_scattered_twice),
      cmocka_unit_test(single_scattering_equals_scattering_at_most_once_on_the_entry_face),
      cmocka_unit_test(single_photon_render_has_zero_standard_errors),
      cmocka_unit_test(values_and_errors_are_finite_and_non_negative),
  };
  return cmocka_run_group_tests(tests, context_setup, ht_context_teardown);
}
