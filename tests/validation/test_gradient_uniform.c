/* The gradient pass in a uniform grid (every voxel alike) against the
 * general path, on a multi-voxel medium.
 *
 * In a uniform grid the library takes a faster path: free flights without
 * voxel stepping, each straight segment logged whole and split into voxels
 * only when a splat follows it, vertex voxels located from their
 * positions. The general path (voxel stepping, per-voxel segments) is the
 * one test_gradient_fd.c validates against finite differences; the
 * single-voxel slab of test_gradient_single_scattering.c exercises the
 * uniform path only with one voxel. Here a gradient at the most common
 * starting point of an optimisation — a homogeneous medium — must be the
 * gradient of the general path.
 *
 * Scene as in test_gradient_fd.c (3 × 3 × 3 voxels of 0.5 mm, η = 1.3, a
 * normal pencil beam at the top centre; an oblique orthographic pixel,
 * steady and with a box bin [1, 3) mm, and a hemispherical detector over
 * the bottom face), but homogeneous: σa = 0.5, σs = 3 /mm, g = 0.4. Its
 * twin differs only in σa of voxel (2,2,2), multiplied by 1 + 1e-9: the
 * grid is no longer uniform, so the general path runs, while every
 * expected value and derivative moves by a relative ~1e-9, a millionth of
 * the Monte Carlo errors here. Both gradients (independent streams) of
 * every value with respect to σa, σs and g of all 27 voxels: 3 · 81 = 243
 * comparisons, z in units of the combined standard error (256 batches
 * each, Welch dof), Bonferroni threshold over the 243. */
#include <math.h>

#include "test_gradient_common.h"

#define COMPARISONS 243
#define VALUES 3
#define PHOTONS 4e5

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0e01)

static const char *const value_name[VALUES] = {"ortho", "bin", "hemi"};

static void uniform_grid_gradient_matches_general_path(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *uniform = val_medium(ctx, (double[]){0, 0, 0}, (double[]){1.5, 1.5, 1.5},
                                        (int32_t[]){3, 3, 3}, 0.5, 3.0, 0.4, 1.3, 1.0, 1);
  hetinv_medium_t *twin = grad_perturbed(uniform, (int32_t[]){2, 2, 2}, HETINV_PARAM_SIGMA_A,
                                         0.5 * (1.0 + 1e-9));
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(uniform, (double[]){0.75, 0.75, 2.5}, (double[]){0, 0, -1}, &beam));
  hetinv_sensor_t *pixel = NULL, *hemi = NULL;
  assert_ok(hetinv_sensor_create_orthographic(uniform, HETINV_FACE_Z_MAX, (double[]){0.3, 0.0, 1.0},
                                              (double[]){0.25, 0.25}, (double[]){1.0, 1.0}, 1, 1, &pixel));
  assert_ok(hetinv_sensor_create_hemispherical(uniform, HETINV_FACE_Z_MIN, NULL, NULL, &hemi));
  hetinv_pathlength_t *steady = NULL, *bin = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 1, (double[]){2.0}, 2.0, &bin));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, pixel, steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, pixel, bin, NULL));
  assert_ok(hetinv_measurements_add(set, beam, hemi, steady, NULL));
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(uniform, HETINV_FREE_ALL, &map));
  hetinv_estimator_t *est = val_estimator(ctx, PHOTONS);

  double t0 = grad_now();
  static double gu[VALUES][81], su[VALUES][81], gt[VALUES][81], st[VALUES][81];
  for (int n = 0; n < VALUES; ++n) {
    double cot[VALUES] = {0};
    cot[n] = 1.0;
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 1));
    assert_ok(hetinv_estimator_gradient(est, uniform, set, cot, VALUES, map, gu[n], su[n], 81));
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 2));
    assert_ok(hetinv_estimator_gradient(est, twin, set, cot, VALUES, map, gt[n], st[n], 81));
  }
  double photons;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_PHOTONS, &photons));
  printf("%d gradient calls of %.0f photons in %.1f s\n", 2 * VALUES, photons, grad_now() - t0);

  int failures = 0;
  for (int n = 0; n < VALUES; ++n) {
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      for (int k = 0; k < 27; ++k) {
        size_t i = (size_t)p * 27 + (size_t)k;
        char name[96];
        snprintf(name, sizeof name, "uniform/%s/%s/(%d,%d,%d)", value_name[n], hetinv_param_name(p),
                 k % 3, (k / 3) % 3, k / 9);
        /* reference: the general path (the twin) */
        failures += !grad_compare(name, gt[n][i], st[n][i], GRAD_BATCH_DOF, gu[n][i], su[n][i],
                                  GRAD_BATCH_DOF, COMPARISONS, seed);
      }
    }
  }
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&bin);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&hemi);
  hetinv_sensor_destroy(&pixel);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&twin);
  hetinv_medium_destroy(&uniform);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(uniform_grid_gradient_matches_general_path),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
