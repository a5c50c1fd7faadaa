/* A camera of a few pixels sees what the whole face's camera sees there.
 *
 * An orthographic camera that looks along its face's normal skips every
 * scattering vertex outside its pixels before any walk or draw (along the
 * normal, each leg of a specular chain keeps the vertex's place on the
 * face), and walks to the boundary along the normal by a table of the
 * optical depth per line of voxels. A 2 × 2 window on a face and the camera
 * over the whole face, each fed by its own (identical) beam, so that their
 * photons are independent, must then agree pixel by pixel within their
 * standard errors: in a heterogeneous medium with mismatched indices
 * (chains reflect off every face), on the lit face and on a side face. */
#include <math.h>
#include <stdlib.h>

#include "validation.h"

#define COMPARISONS 8 /* 2 × 2 pixels on two faces */

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0c3a)

static const double box_lo[3] = {0.0, 0.0, 0.0}, box_hi[3] = {3.0, 3.0, 1.5};
static const val_ranges_t ranges = {{0.3, 0.8}, {1.0, 4.0}, {0.0, 0.6}};
static const double beam_origin[3] = {1.4, 1.6, 3.0}, beam_dir[3] = {0.1, -0.15, -1.0};

/* The whole face's camera (width × height pixels of 0.5 from its corner)
 * against the 2 × 2 window whose first pixel is (u0, v0) of it. */
static int compare_window(const char *name, hetinv_face_t face, int32_t width, int32_t height,
                          int32_t u0, int32_t v0) {
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *m = val_heterogeneous(ctx, box_lo, box_hi, (int32_t[]){3, 3, 2}, &ranges, seed, 1.3, 1.0);
  assert_ok(hetinv_medium_commit(m));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  int axis = face / 2;
  double out[3] = {0.0, 0.0, 0.0};
  out[axis] = (face & 1) ? 1.0 : -1.0;
  const double pixel[2] = {0.5, 0.5}, corner[2] = {0.0, 0.0};
  const double window_corner[2] = {u0 * pixel[0], v0 * pixel[1]};
  hetinv_emitter_t *beam_face = NULL, *beam_window = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, beam_origin, beam_dir, &beam_face));
  assert_ok(hetinv_emitter_create_ideal(m, beam_origin, beam_dir, &beam_window));
  hetinv_sensor_t *whole = NULL, *window = NULL;
  assert_ok(hetinv_sensor_create_orthographic(m, face, out, corner, pixel, width, height, &whole));
  assert_ok(hetinv_sensor_create_orthographic(m, face, out, window_corner, pixel, 2, 2, &window));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam_face, whole, steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam_window, window, steady, NULL));
  size_t n = (size_t)width * (size_t)height + 4;
  double *v = malloc(n * sizeof *v), *se = malloc(n * sizeof *se);
  assert_non_null(v);
  assert_non_null(se);
  hetinv_estimator_t *est = val_estimator(ctx, 4e5);
  assert_ok(hetinv_estimator_render(est, m, set, v, se, NULL, n));
  int failed = 0;
  for (int32_t j = 0; j < 2; ++j) {
    for (int32_t i = 0; i < 2; ++i) {
      size_t w = (size_t)(width * height + j * 2 + i), f = (size_t)((v0 + j) * width + u0 + i);
      char quantity[64];
      snprintf(quantity, sizeof quantity, "window_pixel_%d_%d_vs_whole_face", (int)i, (int)j);
      failed += !val_compare(name, quantity, v[f], se[f], v[w], se[w], val_z_max(COMPARISONS), seed);
    }
  }
  free(v);
  free(se);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_sensor_destroy(&window);
  hetinv_sensor_destroy(&whole);
  hetinv_emitter_destroy(&beam_window);
  hetinv_emitter_destroy(&beam_face);
  hetinv_pathlength_destroy(&steady);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return failed;
}

/* The lit top face (x, y): 6 × 6 pixels, the window at pixels (2-3, 1-2). */
static void top_window_matches_whole_face(void **state) {
  (void)state;
  val_assert_all_passed(compare_window("CW_top", HETINV_FACE_Z_MAX, 6, 6, 2, 1));
}

/* A side face (y, z): 6 × 3 pixels, the window at pixels (3-4, 1-2). */
static void side_window_matches_whole_face(void **state) {
  (void)state;
  val_assert_all_passed(compare_window("CW_side", HETINV_FACE_X_MAX, 6, 3, 3, 1));
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(top_window_matches_whole_face),
      cmocka_unit_test(side_window_matches_whole_face),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
