/* Huber's loss of hetinv_estimator_loss_gradient()
 * (HETINV_ESTIMATOR_LOSS_CLIP): 0 is least squares bit for bit; with a clip
 * c each value's term is w·r² within c standard errors and 2·c·√w·|r| − c²
 * beyond, and the gradient is exactly hetinv_estimator_gradient() on the
 * next stream with the clipped cotangent; the same under a fitted gain;
 * per-value clip scales on each side; and the tunable's and the scales'
 * errors. The checks are exact on one random stream: the
 * loss's render is the `rendered` output, so the terms are known to
 * rounding. */
#include <math.h>
#include <stdio.h>

#include "small_scene.h"

enum { VALUES = SMALL_SCENE_VALUES };

typedef small_scene_t scene_t;

/* The camera on the lit face and the transmittance: 5 values. */
static void scene_init(scene_t *s) {
  small_scene_init(s, 5, 16);
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_STREAM, 21));
}
static void scene_release(scene_t *s) { small_scene_release(s); }

static void assert_close(double expect, double got, double tol) {
  if (!(fabs(expect - got) <= tol)) {
    print_error("expected %.17g, got %.17g (tolerance %g)\n", expect, got, tol);
    fail();
  }
}

/* The loss's gradient grad is exactly hetinv_estimator_gradient() with
 * cotangents cot on the next stream (22). */
static void assert_gradient_of(scene_t *s, const double *cot, const double *grad) {
  double direct[24];
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_STREAM, 22));
  assert_ok(hetinv_estimator_gradient(s->est, s->medium, s->set, cot, VALUES, s->map, direct, NULL, s->k));
  for (size_t i = 0; i < s->k; ++i) assert_close(direct[i], grad[i], 1e-12 * fabs(direct[i]) + 1e-300);
}

/* Measured values around a render of the loss's stream, with weights
 * 1/σ² for σ a tenth of each value: values 1 and 3 sit 2σ off (inside a
 * clip of 3), value 0 sits 40σ high and value 4 60σ low (outside it). */
static void set_measured(scene_t *s, double *m, double *w) {
  double r[VALUES];
  assert_ok(hetinv_estimator_render(s->est, s->medium, s->set, r, NULL, NULL, VALUES));
  static const double off[VALUES] = {-40.0, 2.0, 0.0, -2.0, 60.0};
  for (int n = 0; n < VALUES; ++n) {
    assert_true(r[n] > 0.0);
    double sigma = 0.1 * r[n];
    m[n] = r[n] + off[n] * sigma; /* residual I − Ī = −off·σ */
    w[n] = 1.0 / (sigma * sigma);
  }
  assert_ok(hetinv_measurements_set_values(s->set, m, NULL, VALUES));
  assert_ok(hetinv_measurements_set_weights(s->set, w, VALUES));
}

/* Huber's term of weight w, residual r, clip c, and its slope. */
static double huber(double w, double r, double c, double *slope) {
  double z = sqrt(w) * r; /* the residual in standard errors */
  if (fabs(z) <= c) {
    *slope = 2.0 * w * r;
    return w * r * r;
  }
  *slope = (z > 0 ? 2.0 : -2.0) * c * sqrt(w);
  return 2.0 * c * fabs(z) - c * c;
}

static void default_is_zero_and_zero_is_least_squares_bit_for_bit(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  double clip = -1.0;
  assert_ok(hetinv_estimator_get_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, &clip));
  assert_true(clip == 0.0);
  double m[VALUES], w[VALUES];
  set_measured(&s, m, w);
  double loss0, loss1, g0[24], g1[24], ren[VALUES];
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss0, ren, g0, s.k));
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, 3.0));
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss1, NULL, g1, s.k));
  assert_true(loss1 < loss0); /* the two outliers now count linearly */
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, 0.0));
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss1, NULL, g1, s.k));
  assert_memory_equal(&loss0, &loss1, sizeof loss0);
  assert_memory_equal(g0, g1, sizeof g0);
  double expect = 0.0;
  for (int n = 0; n < VALUES; ++n) expect += w[n] * (ren[n] - m[n]) * (ren[n] - m[n]);
  assert_close(expect, loss0, 1e-13 * expect);
  scene_release(&s);
}

/* The loss is Σ Huber terms of the render, and the gradient is exactly
 * hetinv_estimator_gradient() on stream s + 1 with their slopes: the
 * outliers' cotangents are ±2·c·√w, the others 2·w·r. */
static void clipped_loss_and_gradient_are_the_huber_terms(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  double m[VALUES], w[VALUES];
  set_measured(&s, m, w);
  const double c = 3.0;
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, c));
  double loss, ren[VALUES], grad[24];
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss, ren, grad, s.k));
  double expect = 0.0, cot[VALUES];
  int clipped = 0;
  for (int n = 0; n < VALUES; ++n) {
    expect += huber(w[n], ren[n] - m[n], c, &cot[n]);
    clipped += fabs(cot[n]) < fabs(2.0 * w[n] * (ren[n] - m[n]));
  }
  assert_int_equal(clipped, 2);
  assert_close(expect, loss, 1e-12 * expect);
  assert_gradient_of(&s, cot, grad);
  scene_release(&s);
}

/* A masked outlier enters neither the loss nor the gradient, clip or not. */
static void masked_values_stay_out(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  double m[VALUES], w[VALUES];
  set_measured(&s, m, w);
  uint8_t mask[VALUES] = {0, 1, 1, 1, 0};
  assert_ok(hetinv_measurements_set_mask(s.set, mask, VALUES));
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, 3.0));
  double clipped, plain, g0[24], g1[24];
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &clipped, NULL, g0, s.k));
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, 0.0));
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &plain, NULL, g1, s.k));
  /* The used values are all within the clip: the two losses agree. */
  assert_close(plain, clipped, 1e-13 * plain);
  for (size_t i = 0; i < s.k; ++i) assert_close(g1[i], g0[i], 1e-13 * fabs(g1[i]) + 1e-300);
  scene_release(&s);
}

/* Under a fitted global gain the gain is still least squares, and the
 * terms and cotangents are Huber's at residual k·I − Ī (cotangent k·slope). */
static void clip_applies_to_the_residuals_at_the_fitted_gain(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  double m[VALUES], w[VALUES];
  set_measured(&s, m, w);
  assert_ok(hetinv_estimator_set_gain_mode(s.est, HETINV_GAIN_GLOBAL));
  double plain_loss, grad[24], k_plain, k;
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &plain_loss, NULL, grad, s.k));
  assert_ok(hetinv_estimator_get_gains(s.est, &k_plain, 1, NULL));
  const double c = 3.0;
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, c));
  double loss, ren[VALUES];
  assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss, ren, grad, s.k));
  assert_ok(hetinv_estimator_get_gains(s.est, &k, 1, NULL));
  assert_memory_equal(&k, &k_plain, sizeof k); /* the fit does not see the clip */
  double expect = 0.0, cot[VALUES];
  for (int n = 0; n < VALUES; ++n) {
    double slope;
    expect += huber(w[n], k * ren[n] - m[n], c, &slope);
    cot[n] = k * slope;
  }
  assert_close(expect, loss, 1e-12 * expect);
  assert_true(loss < plain_loss);
  assert_gradient_of(&s, cot, grad);
  scene_release(&s);
}

/* Per-value clip scales: a value whose render is above the data is
 * clipped at c·above of its standard errors, one below at c·below, on the
 * plain loss and at a fitted gain; all-1 scales are the default bit for
 * bit. Residuals are −off·σ: value 0 (+40σ) escapes the clip of 3 at
 * above 20, value 4 (−60σ) stays clipped at below 10, and values 1 (−2σ)
 * and 3 (+2σ) stay inside it on their own side though the other side's
 * scale of 0.5 would clip them. */
static void clip_scales_multiply_each_values_clip_on_its_side(void **state) {
  (void)state;
  for (int gain = 0; gain < 2; ++gain) {
    scene_t s;
    scene_init(&s);
    double m[VALUES], w[VALUES];
    set_measured(&s, m, w);
    if (gain) assert_ok(hetinv_estimator_set_gain_mode(s.est, HETINV_GAIN_GLOBAL));
    const double c = 3.0;
    assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, c));
    for (int n = 0; n < VALUES; ++n) {
      assert_true(hetinv_measurements_clip_scales_below(s.set)[n] == 1.0);
      assert_true(hetinv_measurements_clip_scales_above(s.set)[n] == 1.0);
    }
    double loss1, g1[24];
    assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss1, NULL, g1, s.k));
    const double ones[VALUES] = {1, 1, 1, 1, 1};
    const double below[VALUES] = {1, 1, 0.5, 0.5, 10}, above[VALUES] = {20, 0.5, 1, 1, 1};
    assert_ok(hetinv_measurements_set_clip_scales(s.set, ones, ones, VALUES));
    double loss, ren[VALUES], grad[24], k = 1.0;
    assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss, NULL, grad, s.k));
    assert_memory_equal(&loss1, &loss, sizeof loss);
    assert_memory_equal(g1, grad, sizeof g1);
    assert_ok(hetinv_measurements_set_clip_scales(s.set, below, above, VALUES));
    assert_ok(hetinv_estimator_loss_gradient(s.est, s.medium, s.set, s.map, &loss, ren, grad, s.k));
    if (gain) assert_ok(hetinv_estimator_get_gains(s.est, &k, 1, NULL));
    double expect = 0.0, cot[VALUES];
    int clipped = 0;
    for (int n = 0; n < VALUES; ++n) {
      double slope, r = k * ren[n] - m[n];
      expect += huber(w[n], r, c * (r > 0.0 ? above[n] : below[n]), &slope);
      cot[n] = k * slope;
      clipped += fabs(slope) < fabs(2.0 * w[n] * r);
    }
    if (!gain) assert_int_equal(clipped, 1); /* the fitted gain moves every residual */
    assert_close(expect, loss, 1e-12 * expect);
    assert_gradient_of(&s, cot, grad);
    scene_release(&s);
  }
}

static void bad_clip_scales_get_precise_errors(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  double scale[VALUES] = {1, 2, 0, 1, 1}, ok[VALUES] = {2, 2, 2, 2, 2};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_clip_scales(s.set, scale, ok, VALUES));
  assert_message_contains("below[2]");
  assert_message_contains("is 0; it must be finite and > 0");
  scale[2] = -1.0;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_clip_scales(s.set, ok, scale, VALUES));
  assert_message_contains("above[2]");
  scale[2] = (double)INFINITY;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_clip_scales(s.set, NULL, scale, VALUES));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_clip_scales(s.set, ok, NULL, VALUES - 1));
  assert_message_contains("count is 4; the set has 5 values");
  for (int n = 0; n < VALUES; ++n) { /* nothing changed */
    assert_true(hetinv_measurements_clip_scales_below(s.set)[n] == 1.0);
    assert_true(hetinv_measurements_clip_scales_above(s.set)[n] == 1.0);
  }
  /* NULL is 1: one side alone, and both NULL reset. */
  assert_ok(hetinv_measurements_set_clip_scales(s.set, NULL, ok, VALUES));
  assert_true(hetinv_measurements_clip_scales_below(s.set)[4] == 1.0);
  assert_true(hetinv_measurements_clip_scales_above(s.set)[4] == 2.0);
  assert_ok(hetinv_measurements_set_clip_scales(s.set, NULL, NULL, VALUES));
  assert_true(hetinv_measurements_clip_scales_above(s.set)[4] == 1.0);
  scene_release(&s);
}

static void bad_clips_get_precise_errors(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  double lo = -1, hi = -1;
  assert_ok(hetinv_estimator_param_bounds(HETINV_ESTIMATOR_LOSS_CLIP, &lo, &hi));
  assert_true(lo == 0.0 && hi == 1e6);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, -0.5));
  assert_message_contains("HETINV_ESTIMATOR_LOSS_CLIP is -0.5; it must be a number in [0, 1000000]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, (double)NAN));
  assert_message_contains("HETINV_ESTIMATOR_LOSS_CLIP is nan");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, 2e6));
  double clip = -1;
  assert_ok(hetinv_estimator_get_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, &clip));
  assert_true(clip == 0.0); /* a refused value leaves the old one */
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_LOSS_CLIP, 0.5)); /* not an integer: fine */
  scene_release(&s);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(default_is_zero_and_zero_is_least_squares_bit_for_bit),
      cmocka_unit_test(clipped_loss_and_gradient_are_the_huber_terms),
      cmocka_unit_test(masked_values_stay_out),
      cmocka_unit_test(clip_applies_to_the_residuals_at_the_fitted_gain),
      cmocka_unit_test(clip_scales_multiply_each_values_clip_on_its_side),
      cmocka_unit_test(bad_clip_scales_get_precise_errors),
      cmocka_unit_test(bad_clips_get_precise_errors),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
