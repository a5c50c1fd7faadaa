/* Every failure is attributed to the public function the user called: each
 * recorded message starts with "<that function>: ", whichever helper (or
 * other public function called internally) the failure comes from. One
 * failing call per public function that returns hetinv_result_t, chosen
 * where possible so that the failure originates deep in a helper; a last
 * test parses include/hetinv/ so that a new public function cannot escape
 * the table. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "test_support.h"

#ifndef HETINV_SOURCE_DIR
#error "HETINV_SOURCE_DIR must name the source tree (tests/CMakeLists.txt sets it)"
#endif

enum { MAX_RECORDED = 16, MAX_TESTED = 256, NAME_CAPACITY = 96 };

/* What the context's error callback saw during the current call. */
static struct {
  int count;
  char message[MAX_RECORDED][512];
} recorded;

static void record(void *user, hetinv_result_t code, const char *message) {
  (void)user;
  (void)code;
  if (recorded.count < MAX_RECORDED) {
    snprintf(recorded.message[recorded.count], sizeof recorded.message[0], "%s", message);
  }
  recorded.count++;
}

/* The fixture's context allocates through these; while fail_allocations is
 * set, every allocation fails. */
static bool fail_allocations;

static void *failing_alloc(void *user, size_t size) {
  (void)user;
  return fail_allocations ? NULL : malloc(size);
}

static void failing_free(void *user, void *ptr) {
  (void)user;
  free(ptr);
}

/* Names of the functions the table exercised (for the completeness check). */
static char tested[MAX_TESTED][NAME_CAPACITY];
static int tested_count;

/* Failed expectations; reported all together at the end of the table. */
static int mismatches;

static bool starts_with(const char *s, const char *prefix) {
  return strncmp(s, prefix, strlen(prefix)) == 0;
}

/* A failure of another public function first, so that a call that fails
 * without recording anything cannot pass on a stale message. */
static void plant_other_message(const char *name) {
  double lo, hi;
  if (strcmp(name, "hetinv_estimator_param_bounds") != 0) {
    hetinv_estimator_param_bounds((hetinv_estimator_param_t)-1, &lo, &hi);
  } else {
    hetinv_optimizer_param_bounds((hetinv_optimizer_param_t)-1, &lo, &hi);
  }
}

static void check_failure(const char *name, hetinv_result_t r, const char *file, int line) {
  char prefix[NAME_CAPACITY + 2];
  snprintf(prefix, sizeof prefix, "%s: ", name);
  const char *last = hetinv_context_last_error_message(NULL);
  if (getenv("HT_SHOW_MESSAGES")) fprintf(stderr, "%s\n", last); /* to review the table */
  if (r == HETINV_SUCCESS) {
    print_error("%s:%d: %s succeeded; the test expects it to fail\n", file, line, name);
    mismatches++;
  }
  if (!starts_with(last, prefix)) {
    print_error("%s:%d: %s failed with \"%s\", which does not start with \"%s\"\n", file, line, name,
                last, prefix);
    mismatches++;
  }
  for (int i = 0; i < recorded.count && i < MAX_RECORDED; ++i) {
    if (!starts_with(recorded.message[i], prefix)) {
      print_error("%s:%d: during %s the callback saw \"%s\", which does not start with \"%s\"\n",
                  file, line, name, recorded.message[i], prefix);
      mismatches++;
    }
  }
  if (tested_count < MAX_TESTED) {
    snprintf(tested[tested_count++], NAME_CAPACITY, "%s", name);
  }
}

/* Calls fn args, which must fail with every message naming fn. */
#define EXPECT_FAIL(fn, args) \
  do { \
    plant_other_message(#fn); \
    recorded.count = 0; \
    hetinv_result_t r_ = fn args; \
    check_failure(#fn, r_, __FILE__, __LINE__); \
  } while (0)

/* Public functions returning hetinv_result_t that the table leaves out, and why. */
static const char *const excluded[] = {
    /* Reports the thread's last failure; it never fails itself. */
    "hetinv_context_last_error_code",
    /* Declared only with MPI (hetinv/mpi.h); this test is built without it. Its
     * failures come from the same HV_FAIL path (lib/core/comm.c). */
    "hetinv_context_set_mpi_comm",
};

static const double box_min[3] = {0, 0, 0};
static const double box_max[3] = {1, 1, 1};
static const int32_t dims[3] = {2, 2, 2};

typedef struct fixture {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;  /* committed */
  hetinv_medium_t *mutable_medium;
  hetinv_medium_t *other_grid; /* 3 x 1 x 1, committed */
  hetinv_emitter_t *beam;
  hetinv_sensor_t *ortho, *hemi, *wide; /* wide: 10 x 10 pixels */
  hetinv_pathlength_t *steady, *bins;
  hetinv_measurements_t *set, *empty_set;
  hetinv_estimator_t *estimator;
  hetinv_param_map_t *map;
  hetinv_image_t *image;
  const char *bogus; /* a file that is neither .vol, EXR nor a checkpoint */
} fixture_t;

static void fixture_make(fixture_t *f) {
  memset(f, 0, sizeof *f);
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 2;
  init.seed = 7;
  init.error_fn = record;
  init.alloc_fn = failing_alloc;
  init.free_fn = failing_free;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  hetinv_context_t *ctx = f->ctx;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, dims, &f->medium));
  assert_ok(hetinv_medium_fill(f->medium, 0.1, 1.0, 0.0));
  assert_ok(hetinv_medium_commit(f->medium));
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, dims, &f->mutable_medium));
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){3, 1, 1}, &f->other_grid));
  assert_ok(hetinv_medium_commit(f->other_grid));
  assert_ok(hetinv_emitter_create_ideal(f->medium, (double[]){0.5, 0.5, 0}, (double[]){0, 0, 1},
                                        &f->beam));
  assert_ok(hetinv_sensor_create_orthographic(f->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){0.5, 0.5}, 2, 2,
                                              &f->ortho));
  assert_ok(hetinv_sensor_create_orthographic(f->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){0.1, 0.1}, 10, 10,
                                              &f->wide));
  assert_ok(hetinv_sensor_create_hemispherical(f->medium, HETINV_FACE_Z_MAX, (double[]){0, 0},
                                               (double[]){1, 1}, &f->hemi));
  assert_ok(hetinv_pathlength_create_steady(ctx, &f->steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 2, (double[]){1, 3}, 2,
                                          &f->bins));
  assert_ok(hetinv_measurements_create(ctx, &f->set));
  assert_ok(hetinv_measurements_add(f->set, f->beam, f->ortho, f->bins, NULL));
  assert_ok(hetinv_measurements_add(f->set, f->beam, f->hemi, f->steady, NULL));
  assert_ok(hetinv_measurements_create(ctx, &f->empty_set));
  assert_ok(hetinv_estimator_create(ctx, &f->estimator));
  assert_ok(hetinv_estimator_set_param(f->estimator, HETINV_ESTIMATOR_PHOTONS, 256));
  assert_ok(hetinv_param_map_create_identity(f->medium, HETINV_FREE_ALL, &f->map));
  assert_ok(hetinv_image_create(ctx, 2, 2, 1, &f->image));
  ht_tmpdir_create("error_attribution");
  f->bogus = ht_path("bogus");
  static const char junk[] = "this is not a volume, an image or a checkpoint";
  ht_write_file(f->bogus, junk, sizeof junk);
}

static void fixture_release(fixture_t *f) {
  hetinv_image_destroy(&f->image);
  hetinv_param_map_destroy(&f->map);
  hetinv_estimator_destroy(&f->estimator);
  hetinv_measurements_destroy(&f->set);
  hetinv_measurements_destroy(&f->empty_set);
  hetinv_pathlength_destroy(&f->steady);
  hetinv_pathlength_destroy(&f->bins);
  hetinv_sensor_destroy(&f->ortho);
  hetinv_sensor_destroy(&f->hemi);
  hetinv_sensor_destroy(&f->wide);
  hetinv_emitter_destroy(&f->beam);
  hetinv_medium_destroy(&f->medium);
  hetinv_medium_destroy(&f->mutable_medium);
  hetinv_medium_destroy(&f->other_grid);
  hetinv_context_destroy(&f->ctx);
  ht_tmpdir_remove();
}

/* A directory that does not exist, so that writers fail in hv_atomic_open. */
#define NO_DIR "/nonexistent-hetinv-dir/"

static void test_context_medium_and_sampling(fixture_t *f) {
  hetinv_context_t *ctx = f->ctx;
  hetinv_context_t *no_ctx = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = -3;
  EXPECT_FAIL(hetinv_context_create, (&init, &no_ctx));
  EXPECT_FAIL(hetinv_context_agree, (NULL, HETINV_SUCCESS));

  hetinv_medium_t *m = NULL;
  EXPECT_FAIL(hetinv_medium_create, (ctx, box_min, box_max, (int32_t[]){0, 1, 1}, &m));
  EXPECT_FAIL(hetinv_medium_clone, (NULL, &m));
  EXPECT_FAIL(hetinv_medium_set_ior, (f->mutable_medium, -1.0, 1.0));
  /* check_mutable, a helper */
  EXPECT_FAIL(hetinv_medium_fill, (f->medium, 0.1, 0.1, 0.0));
  /* voxel_index, a helper */
  EXPECT_FAIL(hetinv_medium_set_voxel, (f->mutable_medium, 5, 0, 0, 0.1, 0.1, 0.0));
  /* hv_medium_check_voxel_value, shared with the param maps */
  double negative[8] = {0.1, 0.1, -1.0, 0.1, 0.1, 0.1, 0.1, 0.1};
  EXPECT_FAIL(hetinv_medium_set_grid, (f->mutable_medium, HETINV_PARAM_SIGMA_A, negative, 8));
  EXPECT_FAIL(hetinv_medium_commit, (NULL));
  int32_t d[3];
  double b0[3], b1[3], x, y, z;
  EXPECT_FAIL(hetinv_medium_get_dims, (NULL, d));
  EXPECT_FAIL(hetinv_medium_get_box, (NULL, b0, b1));
  EXPECT_FAIL(hetinv_medium_get_ior, (NULL, &x, &y));
  EXPECT_FAIL(hetinv_medium_get_voxel, (f->medium, 0, 9, 0, &x, &y, &z));

  hetinv_emitter_t *e = NULL;
  /* place_beam / hv_normalize3 */
  EXPECT_FAIL(hetinv_emitter_create_ideal,
              (f->medium, (double[]){0.5, 0.5, 0}, (double[]){0, 0, 0}, &e));
  /* hv_check_face */
  EXPECT_FAIL(hetinv_emitter_create_area, (f->medium, (hetinv_face_t)9, (double[]){0, 0, 1},
                                           (double[]){0, 0}, (double[]){1, 1}, 0, 0, NULL, &e));
  /* check_on_face */
  EXPECT_FAIL(hetinv_emitter_create_diffuse,
              (f->medium, HETINV_FACE_Z_MIN, (double[]){5.0, 5.0}, &e));
  /* build_cdf */
  EXPECT_FAIL(hetinv_emitter_create_combination,
              (f->medium, 2, (double[]){0.5, 0.5, 0, 0.4, 0.4, 0},
               (double[]){0, 0, 1, 0, 0, 1}, (double[]){-1.0, 1.0}, &e));
  hetinv_sensor_t *s = NULL;
  /* set_direction */
  EXPECT_FAIL(hetinv_sensor_create_orthographic,
              (f->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, 0}, (double[]){0, 0},
               (double[]){0.5, 0.5}, 2, 2, &s));
  /* new_sensor's face check */
  EXPECT_FAIL(hetinv_sensor_create_hemispherical,
              (f->medium, (hetinv_face_t)9, (double[]){0, 0}, (double[]){1, 1}, &s));
  /* the centre check, after the sensor is allocated (and freed again) */
  EXPECT_FAIL(hetinv_sensor_create_fiber, (f->medium, HETINV_FACE_Z_MAX, (double[]){0.5, 7.0}, 0.1, 0.22, &s));
  int32_t w, h;
  EXPECT_FAIL(hetinv_sensor_get_size, (NULL, &w, &h));
  hetinv_pathlength_t *p = NULL;
  EXPECT_FAIL(hetinv_pathlength_create_steady, (ctx, NULL));
  EXPECT_FAIL(hetinv_pathlength_create_bins, (ctx, HETINV_WINDOW_BOX, 0, NULL, 1.0, &p));
  /* check_irf, a helper */
  EXPECT_FAIL(hetinv_pathlength_create_bins_irf, (ctx, HETINV_WINDOW_BOX, 1, (double[]){1}, 1.0, 1,
                                                  (double[]){0}, (double[]){(double)NAN}, &p));
  /* the bins' own check, in the public function it calls */
  EXPECT_FAIL(hetinv_pathlength_create_bins_irf, (ctx, HETINV_WINDOW_BOX, 1, (double[]){1}, -1.0, 1,
                                                  (double[]){0}, (double[]){1}, &p));
  double path[1];
  EXPECT_FAIL(hetinv_irf_offsets_from_times, ((double[]){(double)NAN}, 1, 1.0, 1.0, path));

  hetinv_measurements_t *set = NULL;
  EXPECT_FAIL(hetinv_measurements_create, (NULL, &set));
  EXPECT_FAIL(hetinv_measurements_add, (f->set, NULL, f->hemi, f->steady, NULL));
  /* reserve_values, a helper that named itself: growing the values from 64
   * to 128 fails (the row table, 16 rows, has room) */
  fail_allocations = true;
  EXPECT_FAIL(hetinv_measurements_add, (f->set, f->beam, f->wide, f->steady, NULL));
  fail_allocations = false;
  size_t offset;
  int32_t pixels, bins;
  EXPECT_FAIL(hetinv_measurements_row_layout, (f->set, 99, &offset, &pixels, &bins));
  /* check_array, a helper */
  double values[9] = {1, 1, 1, 1, 1, 1, 1, 1, (double)NAN};
  EXPECT_FAIL(hetinv_measurements_set_values, (f->set, values, NULL, 9));
  double weights[9] = {1, 1, 1, 1, 1, 1, 1, 1, -1};
  EXPECT_FAIL(hetinv_measurements_set_weights, (f->set, weights, 9));
  EXPECT_FAIL(hetinv_measurements_set_clip_scales, (f->set, weights, NULL, 9));
  EXPECT_FAIL(hetinv_measurements_set_mask, (f->set, NULL, 9));
  EXPECT_FAIL(hetinv_measurements_mask_saturated, (f->set, (double)NAN, NULL));
}

static void test_acquire_and_param(fixture_t *f) {
  hetinv_noise_model_t model;
  hetinv_noise_model_default(&model);
  model.full_well = -1.0;
  double clean[4] = {1, 2, 3, 4}, noisy[4];
  /* check_model, a helper */
  EXPECT_FAIL(hetinv_noise_apply, (f->ctx, &model, clean, noisy, NULL, 4, NULL));
  hetinv_mixture_spec_t mix;
  hetinv_mixture_spec_default(&mix);
  mix.components = 0;
  /* check_spec, a helper */
  EXPECT_FAIL(hetinv_volume_gaussian_mixture, (f->mutable_medium, &mix));
  hetinv_smoke_spec_t smoke;
  hetinv_smoke_spec_default(&smoke);
  smoke.lo[HETINV_PARAM_SIGMA_S] = -1.0;
  /* hv_volume_check_ranges, shared by the generators */
  EXPECT_FAIL(hetinv_volume_smoke, (f->mutable_medium, &smoke));

  hetinv_param_map_t *map = NULL;
  /* create, a helper */
  EXPECT_FAIL(hetinv_param_map_create_identity, (f->medium, 0, &map));
  EXPECT_FAIL(hetinv_param_map_create_coarse,
              (f->medium, (int32_t[]){0, 1, 1}, HETINV_FREE_ALL, &map));
  EXPECT_FAIL(hetinv_param_map_create_broadcast, (f->medium, 5, HETINV_FREE_ALL, &map));
  int32_t d[3];
  EXPECT_FAIL(hetinv_param_map_get_dims, (NULL, d));
  hetinv_param_t param;
  size_t cell;
  EXPECT_FAIL(hetinv_param_map_entry, (f->map, 1000, &param, &cell));
  double pi[24] = {0}, grad[24];
  /* check_count, a helper */
  EXPECT_FAIL(hetinv_param_map_apply, (f->map, pi, 23, f->mutable_medium));
  /* check_grid, a helper */
  EXPECT_FAIL(hetinv_param_map_extract, (f->map, f->other_grid, pi, 24));
  double voxel_grad[24] = {0};
  EXPECT_FAIL(hetinv_param_map_pullback, (f->map, voxel_grad, grad, 3));
}

static void test_estimator(fixture_t *f) {
  hetinv_estimator_t *e = NULL;
  EXPECT_FAIL(hetinv_estimator_create, (f->ctx, NULL));
  double lo, hi, v;
  EXPECT_FAIL(hetinv_estimator_param_bounds, ((hetinv_estimator_param_t)99, &lo, &hi));
  EXPECT_FAIL(hetinv_estimator_set_param, (f->estimator, HETINV_ESTIMATOR_PHOTONS, -1.0));
  EXPECT_FAIL(hetinv_estimator_get_param, (f->estimator, (hetinv_estimator_param_t)99, &v));
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_ok(hetinv_estimator_create(f->ctx, &e));
  EXPECT_FAIL(hetinv_estimator_get_stats, (e, &stats));
  hetinv_estimator_destroy(&e);
  EXPECT_FAIL(hetinv_estimator_set_gain_mode, (f->estimator, (hetinv_gain_mode_t)7));
  EXPECT_FAIL(hetinv_estimator_get_gain_mode, (f->estimator, NULL));
  EXPECT_FAIL(hetinv_estimator_get_gains, (f->estimator, NULL, 0, NULL)); /* mode none */
  size_t n = 9;
  double values[9], cot[9] = {0}, grad[24], loss;
  /* hv_pass_begin: an uncommitted medium */
  EXPECT_FAIL(hetinv_estimator_render,
              (f->estimator, f->mutable_medium, f->set, values, NULL, NULL, n));
  /* check_map: the map's size */
  EXPECT_FAIL(hetinv_estimator_gradient,
              (f->estimator, f->medium, f->set, cot, n, f->map, grad, NULL, 23));
  /* check_map: a map made for another grid */
  hetinv_param_map_t *other = NULL;
  assert_ok(hetinv_param_map_create_identity(f->other_grid, HETINV_FREE_ALL, &other));
  EXPECT_FAIL(hetinv_estimator_loss_gradient,
              (f->estimator, f->medium, f->set, other, &loss, NULL, grad, 9));
  hetinv_param_map_destroy(&other);
  /* hv_check_pi_map, shared by the J·v and Fisher passes: k or v_count is
   * not the map's size */
  double variances[9] = {1, 1, 1, 1, 1, 1, 1, 1, 1}, out[24], tangent[24] = {0};
  int32_t positive_definite;
  EXPECT_FAIL(hetinv_estimator_jvp,
              (f->estimator, f->medium, f->set, f->map, tangent, 3, values, NULL, n));
  EXPECT_FAIL(hetinv_estimator_fisher,
              (f->estimator, f->medium, f->set, variances, n, f->map, 2, out, NULL, 3));
  EXPECT_FAIL(hetinv_estimator_crb, (f->estimator, f->medium, f->set, variances, n, f->map, 2, out,
                                     NULL, NULL, 3, &positive_definite));
  EXPECT_FAIL(hetinv_estimator_fisher_diagonal,
              (f->estimator, f->medium, f->set, variances, n, f->map, 2, out, NULL, 3));
  EXPECT_FAIL(hetinv_estimator_fisher_blocks,
              (f->estimator, f->medium, f->set, variances, n, f->map, 1, 2, out, NULL, 3));
  /* k is not the map's size */
  EXPECT_FAIL(hetinv_fisher_local_crb, (f->map, variances, 3, 0, out));
  EXPECT_FAIL(hetinv_fisher_blocks_crb, (f->map, variances, 3, out));
}

static void test_io(fixture_t *f) {
  hetinv_context_t *ctx = f->ctx;
  hetinv_vol_header_t header;
  float data[8];
  /* hv_vol_read_file / the parser */
  EXPECT_FAIL(hetinv_vol_read_header, (ctx, f->bogus, &header));
  EXPECT_FAIL(hetinv_vol_read, (ctx, f->bogus, &header, data, 8));
  memset(&header, 0, sizeof header);
  /* check_header, a helper */
  EXPECT_FAIL(hetinv_vol_write, (ctx, ht_path("x.vol"), &header, data, 8));
  EXPECT_FAIL(hetinv_medium_read_vol, (f->mutable_medium, HETINV_PARAM_SIGMA_A, f->bogus));
  /* hv_atomic_open */
  EXPECT_FAIL(hetinv_medium_write_vol, (f->medium, HETINV_PARAM_SIGMA_A, NO_DIR "m.vol"));

  hetinv_image_t *img = NULL;
  /* hv_image_alloc */
  EXPECT_FAIL(hetinv_image_create, (ctx, 0, 1, 1, &img));
  int32_t w, h, c;
  EXPECT_FAIL(hetinv_image_get_size, (NULL, &w, &h, &c));
  /* fail_name, a helper */
  EXPECT_FAIL(hetinv_image_set_channel_name, (f->image, 0, ""));
  EXPECT_FAIL(hetinv_image_find_channel, (f->image, "nope", &c));
  /* check_attribute_name, a helper */
  EXPECT_FAIL(hetinv_image_set_attribute_string, (f->image, "", "x"));
  EXPECT_FAIL(hetinv_image_set_attribute_double, (f->image, "", 1.0));
  EXPECT_FAIL(hetinv_image_set_attribute_int, (f->image, "", 1));
  const char *name, *text;
  hetinv_attribute_type_t type;
  EXPECT_FAIL(hetinv_image_attribute_at, (f->image, 99, &name, &type));
  /* lookup, a helper */
  double dv;
  int32_t iv;
  EXPECT_FAIL(hetinv_image_get_attribute_string, (f->image, "nope", &text));
  EXPECT_FAIL(hetinv_image_get_attribute_double, (f->image, "nope", &dv));
  EXPECT_FAIL(hetinv_image_get_attribute_int, (f->image, "nope", &iv));
  /* hv_atomic_open */
  EXPECT_FAIL(hetinv_image_write_exr, (f->image, NO_DIR "i.exr"));
  /* check_limits, a helper that named itself: more channels than OpenEXR's 32767 */
  hetinv_image_t *wide = NULL;
  assert_ok(hetinv_image_create(ctx, 1, 1, 32768, &wide));
  EXPECT_FAIL(hetinv_image_write_exr, (wide, ht_path("wide.exr")));
  hetinv_image_destroy(&wide);
  EXPECT_FAIL(hetinv_image_write_png, (f->image, 0, NO_DIR "i.png", 0.0, 1.0, 0));
  /* the EXR reader's helpers */
  EXPECT_FAIL(hetinv_image_read_exr, (ctx, f->bogus, &img));
}

/* The progress callback is the user's code: a public function it calls
 * reports its own name, not hetinv_optimizer_run's. */
static char progress_message[512];

static int progress(const hetinv_progress_t *p, void *user) {
  (void)p;
  (void)user;
  hetinv_medium_t *m = NULL;
  hetinv_medium_clone(NULL, &m);
  snprintf(progress_message, sizeof progress_message, "%s", hetinv_context_last_error_message(NULL));
  return 0;
}

static void test_optimizer(fixture_t *f) {
  hetinv_optimizer_t *opt = NULL;
  EXPECT_FAIL(hetinv_optimizer_create, (f->ctx, f->empty_set, f->medium, &opt));
  assert_ok(hetinv_optimizer_create(f->ctx, f->set, f->medium, &opt));
  double lo, hi, v;
  EXPECT_FAIL(hetinv_optimizer_param_bounds, ((hetinv_optimizer_param_t)99, &lo, &hi));
  EXPECT_FAIL(hetinv_optimizer_set_param, (opt, HETINV_OPTIMIZER_LEARNING_RATE, -1.0));
  EXPECT_FAIL(hetinv_optimizer_get_param, (opt, (hetinv_optimizer_param_t)99, &v));
  EXPECT_FAIL(hetinv_optimizer_set_bounds, (opt, HETINV_PARAM_SIGMA_A, 2.0, 1.0));
  hetinv_stage_t stage = {0};
  EXPECT_FAIL(hetinv_optimizer_add_stage, (opt, &stage));
  EXPECT_FAIL(hetinv_optimizer_set_progress, (NULL, NULL, NULL));
  EXPECT_FAIL(hetinv_optimizer_set_checkpoint, (NULL, "x"));
  EXPECT_FAIL(hetinv_optimizer_save, (opt, ht_path("never.ckpt")));
  EXPECT_FAIL(hetinv_optimizer_result, (opt, NULL));
  double pi[24];
  EXPECT_FAIL(hetinv_optimizer_get_pi, (opt, 0, pi, 24));
  hetinv_stage_t one = {sizeof one, f->map, 1, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &one));
  /* read_file, then the format checks */
  EXPECT_FAIL(hetinv_optimizer_resume, (opt, f->bogus));
  /* the run's final checkpoint: run -> hv_checkpoint_write -> hv_atomic_open */
  assert_ok(hetinv_optimizer_set_checkpoint(opt, NO_DIR "run.ckpt"));
  assert_ok(hetinv_optimizer_set_progress(opt, progress, NULL));
  hetinv_stop_reason_t reason;
  EXPECT_FAIL(hetinv_optimizer_run, (opt, f->estimator, &reason));
  if (!starts_with(progress_message, "hetinv_medium_clone: ")) {
    print_error("a failure in the progress callback reads \"%s\"; it must name hetinv_medium_clone\n",
                progress_message);
    mismatches++;
  }
  /* hv_checkpoint_write -> hv_atomic_open */
  EXPECT_FAIL(hetinv_optimizer_save, (opt, NO_DIR "saved.ckpt"));
  /* the public hetinv_optimizer_add_stage refuses (the run has started): the
   * message names the function the user called */
  EXPECT_FAIL(hetinv_optimizer_add_layerwise_stages, (opt, f->map, 0.25, 2, 1));
  hetinv_optimizer_destroy(&opt);
}

static void test_every_public_call(void **state) {
  (void)state;
  fixture_t f;
  fixture_make(&f);
  test_context_medium_and_sampling(&f);
  test_acquire_and_param(&f);
  test_estimator(&f);
  test_io(&f);
  test_optimizer(&f);
  fixture_release(&f);
  assert_int_equal(mismatches, 0);
}

/* After a public call returns, the next failure names the next function: the
 * entry is restored, not left behind. */
static void test_entry_is_left_on_return(void **state) {
  (void)state;
  hetinv_medium_t *m = NULL;
  double lo, hi;
  hetinv_estimator_param_bounds((hetinv_estimator_param_t)99, &lo, &hi);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_clone(NULL, &m));
  assert_true(starts_with(hetinv_context_last_error_message(NULL), "hetinv_medium_clone: "));
  hetinv_estimator_param_bounds((hetinv_estimator_param_t)99, &lo, &hi);
  assert_true(
      starts_with(hetinv_context_last_error_message(NULL), "hetinv_estimator_param_bounds: "));
}

/* The error callback is the user's code too. */
static char callback_message[512];

static void calls_the_library(void *user, hetinv_result_t code, const char *message) {
  (void)user;
  (void)code;
  (void)message;
  double lo, hi;
  hetinv_estimator_param_bounds((hetinv_estimator_param_t)99, &lo, &hi); /* no context: no recursion */
  snprintf(callback_message, sizeof callback_message, "%s", hetinv_context_last_error_message(NULL));
}

static void test_callback_is_outside(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.error_fn = calls_the_library;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_pathlength_create_steady(ctx, NULL));
  hetinv_context_destroy(&ctx);
  if (!starts_with(callback_message, "hetinv_estimator_param_bounds: ")) {
    print_error("a failure in the error callback reads \"%s\"\n", callback_message);
    fail();
  }
}

/* Appends to @p out every "HETINV_API hetinv_result_t <name>(" of @p text. */
static void result_functions(const char *text, char (*out)[NAME_CAPACITY], int *count, int max) {
  static const char api[] = "HETINV_API";
  for (const char *p = strstr(text, api); p != NULL; p = strstr(p + 1, api)) {
    const char *q = p + strlen(api);
    while (*q == ' ' || *q == '\t' || *q == '\n') ++q;
    if (strncmp(q, "hetinv_result_t", 15) != 0) continue;
    q += 15;
    while (*q == ' ' || *q == '\t' || *q == '\n') ++q;
    size_t len = strspn(q, "abcdefghijklmnopqrstuvwxyz0123456789_");
    if (len == 0 || len >= NAME_CAPACITY || *count >= max) continue;
    memcpy(out[*count], q, len);
    out[*count][len] = '\0';
    (*count)++;
  }
}

static char *read_text(const char *path) {
  FILE *fp = fopen(path, "rb");
  assert_non_null(fp);
  assert_int_equal(fseek(fp, 0, SEEK_END), 0);
  long size = ftell(fp);
  assert_true(size >= 0);
  rewind(fp);
  char *text = malloc((size_t)size + 1);
  assert_non_null(text);
  assert_int_equal(fread(text, 1, (size_t)size, fp), (size_t)size);
  text[size] = '\0';
  fclose(fp);
  return text;
}

/* Every public function returning hetinv_result_t is in the table or in the
 * commented exclusions. Runs after test_every_public_call. */
static void test_table_is_complete(void **state) {
  (void)state;
  static char declared[MAX_TESTED][NAME_CAPACITY];
  int declared_count = 0;
  const char *dir_path = HETINV_SOURCE_DIR "/include/hetinv";
  DIR *dir = opendir(dir_path);
  assert_non_null(dir);
  for (struct dirent *ent; (ent = readdir(dir)) != NULL;) {
    size_t len = strlen(ent->d_name);
    if (len < 3 || strcmp(ent->d_name + len - 2, ".h") != 0) continue;
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir_path, ent->d_name);
    char *text = read_text(path);
    result_functions(text, declared, &declared_count, MAX_TESTED);
    free(text);
  }
  closedir(dir);
  assert_true(declared_count > 50); /* the parser found the API */
  int missing = 0;
  for (int i = 0; i < declared_count; ++i) {
    bool found = false;
    for (int j = 0; !found && j < tested_count; ++j) found = strcmp(declared[i], tested[j]) == 0;
    for (size_t j = 0; !found && j < sizeof excluded / sizeof *excluded; ++j) {
      found = strcmp(declared[i], excluded[j]) == 0;
    }
    if (!found) {
      print_error("%s returns hetinv_result_t but has no failing call in this test's table\n",
                  declared[i]);
      missing++;
    }
  }
  assert_int_equal(missing, 0);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_every_public_call),
      cmocka_unit_test(test_entry_is_left_on_return),
      cmocka_unit_test(test_callback_is_outside),
      cmocka_unit_test(test_table_is_complete),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
