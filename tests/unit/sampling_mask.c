/* Masks of saturated and dead values: hetinv_measurements_mask_saturated,
 * and that a masked value (or one of weight 0) changes nothing in the loss,
 * its gradient or the calibration gains, whatever it holds. */
#include <math.h>

#include "small_scene.h"

#define NaN ((double)NAN)
#define Inf ((double)INFINITY)

enum { VALUES = SMALL_SCENE_VALUES };

typedef small_scene_t scene_t;

/* Rows: a 2 x 2 camera and the transmittance: 5 values. */
static void scene_init(scene_t *s) { small_scene_init(s, 3, 8); }
static void scene_release(scene_t *s) { small_scene_release(s); }

static void saturated_values_are_masked_and_others_kept(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  assert_ok(hetinv_measurements_set_values(s.set, (double[]){1.0, 5.0, 10.0, 4.999, -2.0}, NULL, VALUES));
  assert_ok(hetinv_measurements_set_mask(s.set, (uint8_t[]){1, 1, 1, 1, 0}, VALUES)); /* a dead pixel */
  size_t masked = 99;
  assert_ok(hetinv_measurements_mask_saturated(s.set, 5.0, &masked));
  assert_int_equal(masked, 2);
  assert_memory_equal(hetinv_measurements_mask(s.set), ((uint8_t[]){1, 0, 0, 1, 0}), VALUES);
  assert_ok(hetinv_measurements_mask_saturated(s.set, Inf, &masked)); /* +inf: nothing */
  assert_int_equal(masked, 0);
  assert_ok(hetinv_measurements_mask_saturated(s.set, 10.0, NULL));
  assert_memory_equal(hetinv_measurements_mask(s.set), ((uint8_t[]){1, 0, 0, 1, 0}), VALUES);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_mask_saturated(s.set, NaN, &masked));
  assert_message_contains("level is nan");
  assert_memory_equal(hetinv_measurements_mask(s.set), ((uint8_t[]){1, 0, 0, 1, 0}), VALUES);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_mask_saturated(NULL, 1.0, &masked));
  /* the mask's length is checked */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_mask(s.set, (uint8_t[]){1, 1}, 2));
  assert_message_contains("count is 2; the set has 5 values");
  scene_release(&s);
}

/* Loss and gradient for two sets of measured values that differ only in
 * value 1, masked out (mask 0 or weight 0): identical bits, in every gain
 * mode. Without the mask they differ (the test can see a change). */
static void masked_values_change_nothing(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  double r[VALUES];
  assert_ok(hetinv_estimator_render(s.est, s.medium, s.set, r, NULL, NULL, VALUES));
  double a[VALUES], b[VALUES];
  for (int n = 0; n < VALUES; ++n) a[n] = b[n] = 1.5 * r[n] + 0.01 * r[0] * n;
  b[1] = 1e9; /* saturated, then dead */
  const hetinv_gain_mode_t modes[3] = {HETINV_GAIN_NONE, HETINV_GAIN_GLOBAL, HETINV_GAIN_PER_EMITTER};
  for (int how = 0; how < 3; ++how) { /* 0: no mask; 1: mask byte 0; 2: weight 0 */
    for (int m = 0; m < 3; ++m) {
      assert_ok(hetinv_estimator_set_gain_mode(s.est, modes[m]));
      double loss[2], grad[2][24], gain[2] = {0, 0};
      for (int v = 0; v < 2; ++v) {
        assert_ok(hetinv_measurements_set_values(s.set, v ? b : a, NULL, VALUES));
        uint8_t mask[VALUES] = {1, 1, 1, 1, 1};
        double weight[VALUES] = {1, 1, 1, 1, 1};
        /* mask byte 0: set by hand for a, by the saturation level for b */
        if (how == 1 && v == 0) mask[1] = 0;
        assert_ok(hetinv_measurements_set_mask(s.set, mask, VALUES));
        if (how == 1 && v == 1) assert_ok(hetinv_measurements_mask_saturated(s.set, 1e8, NULL));
        if (how == 2) weight[1] = 0.0;
        assert_ok(hetinv_measurements_set_weights(s.set, weight, VALUES));
        assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss[v], NULL,
                                                 grad[v], s.k));
        if (modes[m] != HETINV_GAIN_NONE) assert_ok(hetinv_estimator_get_gains(s.est, &gain[v], 1, NULL));
        if (how == 1) assert_int_equal(hetinv_measurements_mask(s.set)[1], 0);
      }
      if (how == 0) {
        assert_memory_not_equal(&loss[0], &loss[1], sizeof loss[0]);
        assert_memory_not_equal(grad[0], grad[1], sizeof grad[0]);
      } else {
        assert_memory_equal(&loss[0], &loss[1], sizeof loss[0]);
        assert_memory_equal(grad[0], grad[1], sizeof grad[0]);
        assert_memory_equal(&gain[0], &gain[1], sizeof gain[0]);
      }
    }
  }
  scene_release(&s);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(saturated_values_are_masked_and_others_kept),
      cmocka_unit_test(masked_values_change_nothing),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
