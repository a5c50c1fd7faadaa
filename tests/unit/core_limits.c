/* Every count and size of the public API has a documented upper bound
 * (HETINV_MAX_* in the headers), checked before anything is allocated,
 * failing with HETINV_ERROR_INVALID_ARGUMENT and a message naming the
 * value and the bound. And a render stops a path after a default finite
 * number of scattering events, and says how many paths it stopped. */
#include <stdlib.h>

#include "test_support.h"

/* The allocator of every context here: records the largest request, so a
 * test can show that a rejected call allocated nothing big. */
static size_t largest, allocations;

static void *tracking_alloc(void *user, size_t size) {
  (void)user;
  if (size > largest) largest = size;
  ++allocations; /* only counted while one thread allocates */
  return malloc(size);
}

static void tracking_free(void *user, void *p) {
  (void)user;
  free(p);
}

static hetinv_context_t *make_threads_context(int32_t threads) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = tracking_alloc;
  init.free_fn = tracking_free;
  init.thread_count = threads;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  largest = 0;
  return ctx;
}

static hetinv_context_t *make_context(void) { return make_threads_context(2); }

/* Nothing bigger than this is allocated by a rejected call. */
#define SMALL ((size_t)1 << 16)

static const double box_min[3] = {0, 0, 0}, box_max[3] = {1, 1, 1};

static hetinv_medium_t *make_medium(hetinv_context_t *ctx) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){2, 2, 2}, &m));
  assert_ok(hetinv_medium_fill(m, 0.1, 1.0, 0.0));
  assert_ok(hetinv_medium_commit(m));
  return m;
}

static void thread_count_is_bounded(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  hetinv_context_t *ctx = NULL;
  init.thread_count = 65536; /* crashed the OpenMP runtime at the first parallel loop */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_context_create(&init, &ctx));
  assert_message_contains("thread_count is 65536; it must be in [0, HETINV_MAX_THREADS (1024)]");
  assert_null(ctx);
  init.thread_count = HETINV_MAX_THREADS + 1;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_context_create(&init, &ctx));
  init.thread_count = HETINV_MAX_THREADS;
  assert_ok(hetinv_context_create(&init, &ctx));
  assert_int_equal(hetinv_context_thread_count(ctx), HETINV_MAX_THREADS);
  hetinv_context_destroy(&ctx);
  init.thread_count = 0; /* all the runtime offers, within the bound */
  assert_ok(hetinv_context_create(&init, &ctx));
  assert_true(hetinv_context_thread_count(ctx) >= 1 &&
              hetinv_context_thread_count(ctx) <= HETINV_MAX_THREADS);
  hetinv_context_destroy(&ctx);
}

static void voxel_count_is_bounded(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_medium_t *m = NULL;
  /* 2^27 voxels: 3 GB of parameters, allocated before without a word. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){512, 512, 512}, &m));
  assert_message_contains("dims is 512 x 512 x 512 voxels; at most HETINV_MAX_VOXELS (16777216)");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){4097, 4096, 1}, &m));
  assert_null(m);
  assert_true(largest < SMALL);
  hetinv_context_destroy(&ctx);
}

static void sensor_pixel_count_is_bounded(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_medium_t *m = make_medium(ctx);
  largest = 0;
  hetinv_sensor_t *s = NULL;
  const double d[3] = {0, 0, 1}, o[2] = {0, 0}, px[2] = {1.0 / 8192, 1.0 / 8192};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, 8192, 8192, &s));
  assert_message_contains("8192 x 8192 pixels; at most HETINV_MAX_SENSOR_PIXELS (16777216)");
  assert_null(s);
  assert_true(largest < SMALL);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
}

static void emitter_sizes_are_bounded(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_medium_t *m = make_medium(ctx);
  largest = 0;
  hetinv_emitter_t *e = NULL;
  const double d[3] = {0, 0, 1}, lo[2] = {0, 0}, hi[2] = {1, 1};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 4097, 4096, NULL, &e));
  assert_message_contains("the pattern is 4097 x 4096");
  assert_message_contains("HETINV_MAX_PATTERN_CELLS (16777216)");
  /* The count is checked before the arrays are read. */
  const double origin[3] = {0.5, 0.5, -1}, dir[3] = {0, 0, 1}, w[1] = {1};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, HETINV_MAX_COMBINATION_SOURCES + 1, origin, dir,
                                                  w, &e));
  assert_message_contains("count is 1048577; at most HETINV_MAX_COMBINATION_SOURCES (1048576)");
  assert_null(e);
  assert_true(largest < SMALL);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
}

static void pathlength_bin_count_is_bounded(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_pathlength_t *p = NULL;
  const double centre[1] = {1};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, HETINV_MAX_PATHLENGTH_BINS + 1,
                                              centre, 1.0, &p));
  assert_message_contains("count is 65537; at most HETINV_MAX_PATHLENGTH_BINS (65536)");
  assert_null(p);
  assert_true(largest < SMALL);
  hetinv_context_destroy(&ctx);
}

static void measurement_set_size_is_bounded(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_medium_t *m = make_medium(ctx);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *camera = NULL, *hemi = NULL;
  hetinv_pathlength_t *steady = NULL, *bins = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.5, 0.5, -1}, (double[]){0, 0, 1}, &beam));
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MIN, (double[]){0, 0, -1}, (double[]){0, 0},
                                              (double[]){1.0 / 4096, 1.0 / 4096}, 4096, 4096, &camera));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &hemi));
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 5, (double[]){1, 2, 3, 4, 5}, 1, &bins));
  assert_ok(hetinv_measurements_create(ctx, &set));
  largest = 0;
  /* 2^24 pixels x 5 bins: 2 GB of set arrays (and more for a render). */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_add(set, beam, camera, bins, NULL));
  assert_message_contains("16777216 pixels x 5 bins would give the set 83886080 values; at most "
                          "HETINV_MAX_MEASUREMENT_VALUES (67108864)");
  assert_true(largest < SMALL);
  assert_int_equal(hetinv_measurements_row_count(set), 0);
  /* Rows: up to the bound, not one more. */
  for (int32_t i = 0; i < HETINV_MAX_MEASUREMENT_ROWS; ++i) {
    if (hetinv_measurements_add(set, beam, hemi, steady, NULL) != HETINV_SUCCESS) fail();
  }
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_add(set, beam, hemi, steady, NULL));
  assert_message_contains("the set already has 1048576 rows, HETINV_MAX_MEASUREMENT_ROWS");
  assert_int_equal(hetinv_measurements_row_count(set), HETINV_MAX_MEASUREMENT_ROWS);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&bins);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&hemi);
  hetinv_sensor_destroy(&camera);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
}

static void image_size_is_bounded(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_image_t *img = NULL;
  /* 2^15 x 2^15 pixels of 1 channel: 4 GB of floats. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_image_create(ctx, 32768, 32768, 1, &img));
  assert_message_contains("32768 x 32768 pixels of 1 channels are 1073741824 floats; at most "
                          "HETINV_MAX_IMAGE_VALUES (268435456)");
  assert_null(img);
  assert_true(largest < SMALL);
  hetinv_context_destroy(&ctx);
}

static void optimizer_stage_count_is_bounded(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_medium_t *m = make_medium(ctx);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *hemi = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  hetinv_param_map_t *map = NULL;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.5, 0.5, -1}, (double[]){0, 0, 1}, &beam));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &hemi));
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, hemi, steady, NULL));
  assert_ok(hetinv_param_map_create_identity(m, HETINV_FREE_ALL, &map));
  assert_ok(hetinv_optimizer_create(ctx, set, m, &opt));
  /* Layer-wise stages: the count is checked first, before the masks are made. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_optimizer_add_layerwise_stages(opt, map, 0.1, HETINV_MAX_STAGES + 1, 1));
  assert_message_contains("layers is 257; it must be >= 1 and, with the 0 stages already there, "
                          "at most HETINV_MAX_STAGES (256)");
  hetinv_stage_t stage = {sizeof stage, map, 1, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  for (int i = 0; i < HETINV_MAX_STAGES; ++i) assert_ok(hetinv_optimizer_add_stage(opt, &stage));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &stage));
  assert_message_contains("the schedule already has 256 stages, HETINV_MAX_STAGES");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, map, 0.1, 1, 1));
  hetinv_optimizer_destroy(&opt);
  hetinv_param_map_destroy(&map);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&hemi);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
}

/* σs = 1e308: the albedo rounds to 1 and the mean free path is 1e-308, so
 * a photon that enters through z_max (where a step of 1e-308 is below the
 * spacing of doubles: it does not move) never leaves and is never absorbed. With the default bound on
 * scattering events it stops, and the statistics count it. Before the
 * bound the render never finished (the test's timeout would fail it). */
static void endless_paths_are_truncated_and_reported(void **state) {
  (void)state;
  hetinv_context_t *ctx = make_context();
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){1, 1, 1}, &m));
  assert_ok(hetinv_medium_fill(m, 0.0, 1e308, 0.0));
  assert_ok(hetinv_medium_commit(m));
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *hemi = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.5, 0.5, 2}, (double[]){0, 0, -1}, &beam));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &hemi));
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, hemi, steady, NULL));
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(ctx, &est));
  double v = 0;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, &v));
  assert_true(v == HETINV_ESTIMATOR_DEFAULT_MAX_SCATTERING);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 1));
  double value = -1;
  assert_ok(hetinv_estimator_render(est, m, set, &value, NULL, NULL, 1));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("1 photon at sigma_s = 1e308: %.2f s, %llu truncated paths, truncated %g, absorbed %g, "
         "specular %g, escaped %g %g\n", st.seconds, (unsigned long long)st.truncated_paths,
         st.truncated, st.absorbed, st.specular, st.escaped[4], st.escaped[5]);
  assert_true(st.truncated_paths == 1); /* it entered (eta = 1) and was stopped */
  assert_true(st.truncated == 1.0);
  assert_true(value == 0.0);
  /* A smaller explicit bound is counted the same way. */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 10));
  assert_ok(hetinv_estimator_render(est, m, set, &value, NULL, NULL, 1));
  assert_ok(hetinv_estimator_get_stats(est, &st));
  assert_true(st.truncated_paths == 1);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&hemi);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
}

/* Each render thread holds a tally as large as the set: a render never runs
 * (nor allocates for) more threads than it has work items (emitters x
 * batches), whatever the context's thread count. */
static size_t render_allocations(int32_t threads) {
  hetinv_context_t *ctx = make_threads_context(threads);
  hetinv_medium_t *m = make_medium(ctx);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *camera = NULL;
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.5, 0.5, -1}, (double[]){0, 0, 1}, &beam));
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MIN, (double[]){0, 0, -1}, (double[]){0, 0},
                                              (double[]){0.25, 0.25}, 4, 4, &camera));
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, camera, steady, NULL));
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(ctx, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 100));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2)); /* 2 work items */
  double values[16];
  allocations = 0;
  assert_ok(hetinv_estimator_render(est, m, set, values, NULL, NULL, 16));
  size_t n = allocations;
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&camera);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return n;
}

static void render_threads_are_bounded_by_work_items(void **state) {
  (void)state;
  size_t two = render_allocations(2), many = render_allocations(HETINV_MAX_THREADS);
  printf("render allocations: %zu with 2 threads, %zu with %d\n", two, many, HETINV_MAX_THREADS);
  assert_true(many == two);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(thread_count_is_bounded),
      cmocka_unit_test(voxel_count_is_bounded),
      cmocka_unit_test(sensor_pixel_count_is_bounded),
      cmocka_unit_test(emitter_sizes_are_bounded),
      cmocka_unit_test(pathlength_bin_count_is_bounded),
      cmocka_unit_test(measurement_set_size_is_bounded),
      cmocka_unit_test(image_size_is_bounded),
      cmocka_unit_test(optimizer_stage_count_is_bounded),
      cmocka_unit_test(endless_paths_are_truncated_and_reported),
      cmocka_unit_test(render_threads_are_bounded_by_work_items),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
