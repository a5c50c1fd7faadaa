/* A measurement set's geometry hash (estimator/set_hash.c), which
 * optimizer checkpoints store: the same set built again, in another
 * context, hashes alike; a change of any one thing that shapes the
 * rendered values (the box's index, an ideal beam's entry, an area
 * source's pattern, a diffuse source's point, a camera's direction, a
 * hemispherical detector's rectangle, a bin's width, an instrument
 * response) changes it; the measured values change the values hash only. */
#include <stdlib.h>

#include "estimator/set_hash.h"
#include "test_support.h"

/* What variant v changes (0: nothing). */
enum {
  SAME,
  ETA,
  BEAM,
  PATTERN,
  DIFFUSE,
  CAMERA,
  RECTANGLE,
  BIN_WIDTH,
  IRF,
  VARIANTS
};

typedef struct built {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam, *area, *diffuse;
  hetinv_sensor_t *camera, *hemi;
  hetinv_pathlength_t *bins, *irf;
  hetinv_measurements_t *set;
} built_t;

static void build(built_t *b, int v) {
  assert_ok(hetinv_context_create(NULL, &b->ctx));
  assert_ok(hetinv_medium_create(b->ctx, (double[]){0, 0, 0}, (double[]){2, 1, 1}, (int32_t[]){2, 1, 2}, &b->medium));
  assert_ok(hetinv_medium_set_ior(b->medium, v == ETA ? 1.4 : 1.3, 1.0));
  assert_ok(hetinv_medium_fill(b->medium, 0.1, 1.0, 0.2));
  assert_ok(hetinv_medium_commit(b->medium));
  assert_ok(hetinv_emitter_create_ideal(b->medium, (double[]){v == BEAM ? 0.75 : 0.5, 0.5, -1}, (double[]){0, 0, 1},
                                        &b->beam));
  const double pattern[4] = {1, 2, 3, v == PATTERN ? 5 : 4};
  assert_ok(hetinv_emitter_create_area(b->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, 1}, (double[]){0, 0},
                                       (double[]){2, 1}, 2, 2, pattern, &b->area));
  assert_ok(hetinv_emitter_create_diffuse(b->medium, HETINV_FACE_X_MIN, (double[]){0.5, v == DIFFUSE ? 0.25 : 0.5},
                                          &b->diffuse));
  assert_ok(hetinv_sensor_create_orthographic(b->medium, HETINV_FACE_Z_MAX, (double[]){v == CAMERA ? 0.1 : 0, 0, 1},
                                              (double[]){0, 0}, (double[]){1, 1}, 2, 1, &b->camera));
  assert_ok(hetinv_sensor_create_hemispherical(b->medium, HETINV_FACE_Z_MIN, (double[]){0, 0},
                                               (double[]){v == RECTANGLE ? 1.5 : 2, 1}, &b->hemi));
  const double centres[2] = {1, 3};
  assert_ok(hetinv_pathlength_create_bins(b->ctx, HETINV_WINDOW_BOX, 2, centres, v == BIN_WIDTH ? 1.5 : 2, &b->bins));
  const double offsets[2] = {0, 0.5}, samples[2] = {1, v == IRF ? 0.75 : 0.5};
  assert_ok(hetinv_pathlength_create_bins_irf(b->ctx, HETINV_WINDOW_BOX, 2, centres, 2, 2, offsets, samples, &b->irf));
  assert_ok(hetinv_measurements_create(b->ctx, &b->set));
  assert_ok(hetinv_measurements_add(b->set, b->beam, b->camera, b->bins, NULL));
  assert_ok(hetinv_measurements_add(b->set, b->area, b->hemi, b->irf, NULL));
  assert_ok(hetinv_measurements_add(b->set, b->diffuse, b->camera, b->bins, NULL));
}

static void release(built_t *b) {
  hetinv_measurements_destroy(&b->set);
  hetinv_pathlength_destroy(&b->bins);
  hetinv_pathlength_destroy(&b->irf);
  hetinv_sensor_destroy(&b->camera);
  hetinv_sensor_destroy(&b->hemi);
  hetinv_emitter_destroy(&b->beam);
  hetinv_emitter_destroy(&b->area);
  hetinv_emitter_destroy(&b->diffuse);
  hetinv_medium_destroy(&b->medium);
  hetinv_context_destroy(&b->ctx);
}

static void the_same_set_hashes_alike_and_any_change_differs(void **state) {
  (void)state;
  built_t a, b;
  build(&a, SAME);
  build(&b, SAME);
  assert_true(hv_set_geometry_hash(a.set) == hv_set_geometry_hash(b.set));
  assert_true(hv_set_values_hash(a.set) == hv_set_values_hash(b.set));
  release(&b);
  for (int v = SAME + 1; v < VARIANTS; ++v) {
    build(&b, v);
    if (hv_set_geometry_hash(a.set) == hv_set_geometry_hash(b.set)) {
      print_error("variant %d hashes as the original set\n", v);
      fail();
    }
    release(&b);
  }
  release(&a);
}

static void measured_values_change_the_values_hash_only(void **state) {
  (void)state;
  built_t a;
  build(&a, SAME);
  uint64_t geometry = hv_set_geometry_hash(a.set), values = hv_set_values_hash(a.set);
  size_t n = hetinv_measurements_value_count(a.set);
  double *v = calloc(n, sizeof *v);
  assert_non_null(v);
  v[n - 1] = 1.0;
  assert_ok(hetinv_measurements_set_values(a.set, v, NULL, n));
  assert_true(hv_set_geometry_hash(a.set) == geometry);
  assert_true(hv_set_values_hash(a.set) != values);
  free(v);
  release(&a);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(the_same_set_hashes_alike_and_any_change_differs),
      cmocka_unit_test(measured_values_change_the_values_hash_only),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
