/* A heterogeneous medium whose voxels all hold the same values is the
 * homogeneous medium: a 5 × 4 × 3 grid of equal voxels must give the
 * 1-voxel answer. The tracking is exact in law (free flights by delta
 * tracking, whose majorant here equals every voxel's σt; connections to
 * the sensors stepped voxel by voxel), so the random histories differ
 * between the two grids; to compare statistically with independent errors,
 * the two renders use different random streams. (The library recognises
 * grids of identical voxels and tracks them as one voxel; one voxel of the
 * grid differs by one ulp of g so that the grid's trackers are what is
 * compared with the single voxel.)
 *
 * η = 1.3, so photons cross voxel faces both in free flight and along the
 * specular chains of next-event connections. Compared: hemispherical
 * detectors on the top, bottom and a side face, a 2 × 2 orthographic
 * sensor, three Gaussian pathlength windows of the top detector, and the
 * absorbed fraction. */
#include <math.h>

#include "validation.h"

#define COMPARISONS 11
#define VALUES 10

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed005e)

static const double box_lo[3] = {0.0, 0.0, 0.0}, box_hi[3] = {3.0, 2.5, 2.0};

typedef struct render_out {
  double v[VALUES], se[VALUES];
  double absorbed, absorbed_se;
} render_out_t;

static render_out_t render(const int32_t dims[3], uint32_t stream) {
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *m = val_medium(ctx, box_lo, box_hi, dims, 0.4, 2.5, 0.6, 1.3, 1.0, 0);
  if (dims[0] * dims[1] * dims[2] > 1) {
    /* One voxel's g one ulp higher (a relative change of 2e-16): the
     * library tracks grids whose voxels are all equal as one voxel, and
     * this keeps the voxel-by-voxel tracking under test. */
    assert_ok(hetinv_medium_set_voxel(m, 2, 1, 1, 0.4, 2.5, nextafter(0.6, 1.0)));
  }
  assert_ok(hetinv_medium_commit(m));
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){1.3, 1.1, 3.0}, (double[]){0.2, 0.1, -1.0}, &beam));
  hetinv_sensor_t *s[4] = {NULL};
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &s[0]));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &s[1]));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Y_MIN, NULL, NULL, &s[2]));
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){-0.2, 0.3, 1.0},
                                              (double[]){0.8, 0.5}, (double[]){0.7, 0.7}, 2, 2, &s[3]));
  hetinv_pathlength_t *steady = NULL, *gauss = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_GAUSSIAN, 3, (double[]){1.5, 4.0, 8.0},
                                          0.5, &gauss));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  for (int i = 0; i < 4; ++i) assert_ok(hetinv_measurements_add(set, beam, s[i], steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, s[0], gauss, NULL));
  assert_int_equal(hetinv_measurements_value_count(set), VALUES);
  hetinv_estimator_t *est = val_estimator(ctx, 3e5);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, stream));
  render_out_t out;
  assert_ok(hetinv_estimator_render(est, m, set, out.v, out.se, NULL, VALUES));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render (%d x %d x %d voxels): %llu photons in %.2f s\n", (int)dims[0], (int)dims[1],
         (int)dims[2], (unsigned long long)st.photons, st.seconds);
  out.absorbed = st.absorbed;
  out.absorbed_se = st.absorbed_std_error;
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_pathlength_destroy(&gauss);
  for (int i = 0; i < 4; ++i) hetinv_sensor_destroy(&s[i]);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return out;
}

static void uniform_grid_matches_single_voxel(void **state) {
  (void)state;
  render_out_t one = render((int32_t[]){1, 1, 1}, 0);
  render_out_t grid = render((int32_t[]){5, 4, 3}, 1);
  static const char *names[VALUES] = {
      "hemi_top", "hemi_bottom", "hemi_side_y_min", "pixel0", "pixel1", "pixel2", "pixel3",
      "hemi_top_gauss_tau1.5", "hemi_top_gauss_tau4", "hemi_top_gauss_tau8"};
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  for (int i = 0; i < VALUES; ++i) {
    failures += !val_compare("UG", names[i], one.v[i], one.se[i], grid.v[i], grid.se[i], z_max, seed);
  }
  failures += !val_compare("UG", "absorbed", one.absorbed, one.absorbed_se, grid.absorbed,
                           grid.absorbed_se, z_max, seed);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(uniform_grid_matches_single_voxel),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
