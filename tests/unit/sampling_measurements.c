/* Measurement sets: row layout, the value/weight/mask arrays and their
 * validation, and the rule that a set does not mix media. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

#define NaN ((double)NAN)
#define Inf ((double)INFINITY)

static const double box_min[3] = {0, 0, 0};
static const double box_max[3] = {10, 10, 10};

static hetinv_medium_t *make_medium(hetinv_context_t *ctx, const double lo[3], const double hi[3],
                                    double eta) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, lo, hi, (int32_t[]){1, 1, 1}, &m));
  assert_ok(hetinv_medium_set_ior(m, eta, 1.0));
  return m;
}

/* Sampling functions for a set, all from one medium:
 *   row 0: pencil beam, orthographic 4 x 3 sensor, steady   -> 12 values at 0
 *   row 1: pencil beam, hemispherical detector, 5 bins      ->  5 values at 12
 *   row 2: pencil beam, orthographic 4 x 3 sensor, 2 bins   -> 24 values at 17
 * 41 values in all. */
typedef struct fixture {
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *ortho, *hemi;
  hetinv_pathlength_t *steady, *bins5, *bins2;
  hetinv_measurements_t *set;
} fixture_t;

static void fixture_init(hetinv_context_t *ctx, fixture_t *f) {
  *f = (fixture_t){0};
  f->medium = make_medium(ctx, box_min, box_max, 1.4);
  assert_ok(hetinv_emitter_create_ideal(f->medium, (double[]){5, 5, -1}, (double[]){0, 0, 1}, &f->beam));
  assert_ok(hetinv_sensor_create_orthographic(f->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){2.5, 2.5}, 4, 3, &f->ortho));
  assert_ok(hetinv_sensor_create_hemispherical(f->medium, HETINV_FACE_Z_MAX, NULL, NULL, &f->hemi));
  assert_ok(hetinv_pathlength_create_steady(ctx, &f->steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 5, (double[]){1, 2, 3, 4, 5}, 1, &f->bins5));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_GAUSSIAN, 2, (double[]){10, 20}, 2, &f->bins2));
  assert_ok(hetinv_measurements_create(ctx, &f->set));
}

/* Adds the three rows described above. */
static void fixture_add_rows(fixture_t *f) {
  int32_t row = -1;
  assert_ok(hetinv_measurements_add(f->set, f->beam, f->ortho, f->steady, &row));
  assert_int_equal(row, 0);
  assert_ok(hetinv_measurements_add(f->set, f->beam, f->hemi, f->bins5, &row));
  assert_int_equal(row, 1);
  assert_ok(hetinv_measurements_add(f->set, f->beam, f->ortho, f->bins2, &row));
  assert_int_equal(row, 2);
}

static void fixture_release(fixture_t *f) {
  hetinv_measurements_destroy(&f->set);
  hetinv_pathlength_destroy(&f->steady);
  hetinv_pathlength_destroy(&f->bins5);
  hetinv_pathlength_destroy(&f->bins2);
  hetinv_sensor_destroy(&f->ortho);
  hetinv_sensor_destroy(&f->hemi);
  hetinv_emitter_destroy(&f->beam);
  hetinv_medium_destroy(&f->medium);
}

enum { FIXTURE_VALUES = 41 };

/* ------------------------------------------------------------------------ */

static void new_set_is_empty(void **state) {
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(*state, &set));
  assert_non_null(set);
  assert_int_equal(hetinv_measurements_row_count(set), 0);
  assert_int_equal(hetinv_measurements_value_count(set), 0);
  assert_null(hetinv_measurements_values(set));
  assert_null(hetinv_measurements_std_errors(set));
  assert_null(hetinv_measurements_weights(set));
  assert_null(hetinv_measurements_mask(set));
  hetinv_measurements_destroy(&set);
  assert_null(set);
}

static void create_rejects_null_arguments(void **state) {
  hetinv_measurements_t *set = (hetinv_measurements_t *)ht_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_create(*state, NULL));
  assert_message_contains("'out' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_create(NULL, &set));
  assert_message_contains("'ctx' is NULL");
  assert_null(set);
}

static void rows_follow_one_another(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  assert_int_equal(hetinv_measurements_row_count(f.set), 3);
  assert_int_equal(hetinv_measurements_value_count(f.set), FIXTURE_VALUES);
  size_t offset = 99;
  int32_t pixels = -1, bins = -1;
  assert_ok(hetinv_measurements_row_layout(f.set, 0, &offset, &pixels, &bins));
  assert_int_equal(offset, 0);
  assert_int_equal(pixels, 12);
  assert_int_equal(bins, 1);
  assert_ok(hetinv_measurements_row_layout(f.set, 1, &offset, &pixels, &bins));
  assert_int_equal(offset, 12);
  assert_int_equal(pixels, 1);
  assert_int_equal(bins, 5);
  assert_ok(hetinv_measurements_row_layout(f.set, 2, &offset, &pixels, &bins));
  assert_int_equal(offset, 17);
  assert_int_equal(pixels, 12);
  assert_int_equal(bins, 2);
  fixture_release(&f);
}

static void add_accepts_a_null_row_output(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  assert_ok(hetinv_measurements_add(f.set, f.beam, f.hemi, f.steady, NULL));
  assert_ok(hetinv_measurements_add(f.set, f.beam, f.hemi, f.steady, NULL));
  assert_int_equal(hetinv_measurements_row_count(f.set), 2);
  assert_int_equal(hetinv_measurements_value_count(f.set), 2);
  fixture_release(&f);
}

static void row_layout_accepts_null_outputs(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  assert_ok(hetinv_measurements_row_layout(f.set, 2, NULL, NULL, NULL));
  int32_t bins = 0;
  assert_ok(hetinv_measurements_row_layout(f.set, 1, NULL, NULL, &bins));
  assert_int_equal(bins, 5);
  fixture_release(&f);
}

static void row_layout_rejects_unknown_rows(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  size_t offset;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_measurements_row_layout(f.set, 0, &offset, NULL, NULL));
  assert_message_contains("row 0 does not exist; the set has 0 rows");
  fixture_add_rows(&f);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_measurements_row_layout(f.set, 3, &offset, NULL, NULL));
  assert_message_contains("row 3 does not exist; the set has 3 rows");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_measurements_row_layout(f.set, -1, &offset, NULL, NULL));
  assert_message_contains("row -1 does not exist");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_row_layout(NULL, 0, &offset, NULL, NULL));
  assert_message_contains("'set' is NULL");
  fixture_release(&f);
}

static void new_rows_have_value_zero_weight_one_and_are_used(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  const double *v = hetinv_measurements_values(f.set);
  const double *e = hetinv_measurements_std_errors(f.set);
  const double *w = hetinv_measurements_weights(f.set);
  const uint8_t *k = hetinv_measurements_mask(f.set);
  assert_non_null(v);
  assert_non_null(e);
  assert_non_null(w);
  assert_non_null(k);
  for (int i = 0; i < FIXTURE_VALUES; ++i) {
    assert_true(v[i] == 0.0);
    assert_true(e[i] == 0.0);
    assert_true(w[i] == 1.0);
    assert_int_equal(k[i], 1);
  }
  fixture_release(&f);
}

static void adding_rows_keeps_earlier_values(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES], e[FIXTURE_VALUES], w[FIXTURE_VALUES];
  uint8_t k[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) {
    v[i] = i + 0.5, e[i] = 0.01 * i, w[i] = 2.0 * i, k[i] = (uint8_t)(i % 2);
  }
  assert_ok(hetinv_measurements_set_values(f.set, v, e, FIXTURE_VALUES));
  assert_ok(hetinv_measurements_set_weights(f.set, w, FIXTURE_VALUES));
  assert_ok(hetinv_measurements_set_mask(f.set, k, FIXTURE_VALUES));
  /* Enough new values to make the set grow its arrays. */
  hetinv_sensor_t *big = NULL;
  assert_ok(hetinv_sensor_create_orthographic(f.medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){1, 1}, 30, 20, &big));
  assert_ok(hetinv_measurements_add(f.set, f.beam, big, f.bins2, NULL));
  size_t n = hetinv_measurements_value_count(f.set);
  assert_int_equal(n, FIXTURE_VALUES + 1200);
  const double *sv = hetinv_measurements_values(f.set);
  const double *se = hetinv_measurements_std_errors(f.set);
  const double *sw = hetinv_measurements_weights(f.set);
  const uint8_t *sk = hetinv_measurements_mask(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) {
    assert_true(sv[i] == v[i] && se[i] == e[i] && sw[i] == w[i]);
    assert_int_equal(sk[i], k[i]);
  }
  for (size_t i = FIXTURE_VALUES; i < n; ++i) {
    assert_true(sv[i] == 0.0 && se[i] == 0.0 && sw[i] == 1.0);
    assert_int_equal(sk[i], 1);
  }
  hetinv_measurements_destroy(&f.set); /* before the sensor it borrows */
  hetinv_sensor_destroy(&big);
  fixture_release(&f);
}

static void rows_may_share_sampling_functions(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  for (int i = 0; i < 50; ++i) assert_ok(hetinv_measurements_add(f.set, f.beam, f.hemi, f.bins5, NULL));
  assert_int_equal(hetinv_measurements_row_count(f.set), 50);
  assert_int_equal(hetinv_measurements_value_count(f.set), 250);
  size_t offset;
  assert_ok(hetinv_measurements_row_layout(f.set, 49, &offset, NULL, NULL));
  assert_int_equal(offset, 245);
  fixture_release(&f);
}

static void add_rejects_null_arguments(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_add(NULL, f.beam, f.hemi, f.steady, NULL));
  assert_message_contains("'set' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_add(f.set, NULL, f.hemi, f.steady, NULL));
  assert_message_contains("'emitter' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_add(f.set, f.beam, NULL, f.steady, NULL));
  assert_message_contains("'sensor' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_add(f.set, f.beam, f.hemi, NULL, NULL));
  assert_message_contains("'pathlength' is NULL");
  assert_int_equal(hetinv_measurements_row_count(f.set), 0);
  fixture_release(&f);
}

static void rows_from_media_with_different_boxes_are_rejected(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  hetinv_medium_t *other = make_medium(*state, box_min, (double[]){10, 10, 11}, 1.4);
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *hemi = NULL;
  assert_ok(hetinv_emitter_create_ideal(other, (double[]){5, 5, -1}, (double[]){0, 0, 1}, &beam));
  assert_ok(hetinv_sensor_create_hemispherical(other, HETINV_FACE_Z_MAX, NULL, NULL, &hemi));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_add(f.set, beam, f.hemi, f.steady, NULL));
  assert_message_contains("the emitter was created from a medium whose box or refractive indices "
                          "differ from those of the set's earlier rows (box_max[z] 11 against 10); "
                          "a measurement set must not mix media");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_add(f.set, f.beam, hemi, f.steady, NULL));
  assert_message_contains("the sensor was created from a medium");
  assert_message_contains("must not mix media");
  /* Nothing was added. */
  assert_int_equal(hetinv_measurements_row_count(f.set), 3);
  assert_int_equal(hetinv_measurements_value_count(f.set), FIXTURE_VALUES);
  hetinv_sensor_destroy(&hemi);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&other);
  fixture_release(&f);
}

static void rows_from_media_with_different_indices_are_rejected(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  hetinv_medium_t *other = make_medium(*state, box_min, box_max, 1.33); /* fixture: 1.4 */
  hetinv_sensor_t *hemi = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(other, HETINV_FACE_Z_MAX, NULL, NULL, &hemi));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_add(f.set, f.beam, hemi, f.steady, NULL));
  assert_message_contains("the sensor was created from a medium whose box or refractive indices differ");
  assert_message_contains("must not mix media");
  hetinv_sensor_destroy(&hemi);
  hetinv_medium_destroy(&other);
  /* The outside index counts too. */
  other = make_medium(*state, box_min, box_max, 1.4);
  assert_ok(hetinv_medium_set_ior(other, 1.4, 1.0003));
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(other, (double[]){5, 5, -1}, (double[]){0, 0, 1}, &beam));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_add(f.set, beam, f.hemi, f.steady, NULL));
  assert_message_contains("(eta (outside) 1.0003 against 1); a measurement set must not mix media");
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&other);
  fixture_release(&f);
}

static void first_row_must_not_mix_media(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  hetinv_medium_t *other = make_medium(*state, (double[]){-1, 0, 0}, box_max, 1.4);
  hetinv_sensor_t *hemi = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(other, HETINV_FACE_Z_MAX, NULL, NULL, &hemi));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_add(f.set, f.beam, hemi, f.steady, NULL));
  assert_message_contains("the sensor was created from a medium whose box or refractive indices "
                          "differ from those of the row's emitter (box_min[x] -1 against 0); "
                          "a measurement set must not mix media");
  assert_int_equal(hetinv_measurements_row_count(f.set), 0);
  hetinv_sensor_destroy(&hemi);
  hetinv_medium_destroy(&other);
  fixture_release(&f);
}

static void media_with_equal_box_and_indices_mix(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  /* Another grid and other coefficients, same box and indices. */
  hetinv_medium_t *other = NULL;
  assert_ok(hetinv_medium_create(*state, box_min, box_max, (int32_t[]){3, 4, 5}, &other));
  assert_ok(hetinv_medium_set_ior(other, 1.4, 1.0));
  assert_ok(hetinv_medium_fill(other, 0.1, 2, 0.8));
  hetinv_sensor_t *hemi = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(other, HETINV_FACE_X_MIN, NULL, NULL, &hemi));
  assert_ok(hetinv_measurements_add(f.set, f.beam, hemi, f.steady, NULL));
  assert_int_equal(hetinv_measurements_row_count(f.set), 4);
  hetinv_measurements_destroy(&f.set);
  hetinv_sensor_destroy(&hemi);
  hetinv_medium_destroy(&other);
  fixture_release(&f);
}

/* A box corner at -0.0 is the same box as one at +0.0. */
static void media_whose_boxes_differ_only_in_the_sign_of_zero_mix(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  hetinv_medium_t *other = make_medium(*state, (double[]){-0.0, 0, 0}, box_max, 1.4);
  hetinv_sensor_t *hemi = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(other, HETINV_FACE_X_MIN, NULL, NULL, &hemi));
  assert_ok(hetinv_measurements_add(f.set, f.beam, hemi, f.steady, NULL));
  hetinv_measurements_destroy(&f.set);
  hetinv_sensor_destroy(&hemi);
  hetinv_medium_destroy(&other);
  fixture_release(&f);
}

static void set_values_copies_values_and_errors(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES], e[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) v[i] = -1.0 + 0.25 * i, e[i] = 0.5 * i;
  assert_ok(hetinv_measurements_set_values(f.set, v, e, FIXTURE_VALUES));
  v[3] = 1000, e[3] = 1000; /* copied, not borrowed */
  const double *sv = hetinv_measurements_values(f.set), *se = hetinv_measurements_std_errors(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) {
    assert_true(sv[i] == -1.0 + 0.25 * i);
    assert_true(se[i] == 0.5 * i);
  }
  fixture_release(&f);
}

static void set_values_without_errors_resets_them_to_zero(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES], e[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) v[i] = i, e[i] = 1;
  assert_ok(hetinv_measurements_set_values(f.set, v, e, FIXTURE_VALUES));
  assert_ok(hetinv_measurements_set_values(f.set, v, NULL, FIXTURE_VALUES));
  const double *se = hetinv_measurements_std_errors(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) assert_true(se[i] == 0.0);
  fixture_release(&f);
}

static void set_values_rejects_a_count_mismatch(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES + 1] = {0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v, NULL, FIXTURE_VALUES + 1));
  assert_message_contains("count is 42; the set has 41 values");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v, NULL, 12));
  assert_message_contains("count is 12; the set has 41 values");
  fixture_release(&f);
}

/* Value index offset + bin·pixels + pixel: the message decodes it. */
static void set_values_names_row_pixel_and_bin_of_a_non_finite_value(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES] = {0};
  v[17 + 1 * 12 + 5] = NaN;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v, NULL, FIXTURE_VALUES));
  assert_message_contains("values[34] (row 2, pixel 5, bin 1) is nan; it must be finite");
  v[34] = 0;
  v[12 + 3] = -Inf;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v, NULL, FIXTURE_VALUES));
  assert_message_contains("values[15] (row 1, pixel 0, bin 3) is -inf");
  v[15] = 0;
  v[11] = Inf;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v, NULL, FIXTURE_VALUES));
  assert_message_contains("values[11] (row 0, pixel 11, bin 0) is inf");
  fixture_release(&f);
}

static void set_values_rejects_negative_or_non_finite_errors(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES] = {0}, e[FIXTURE_VALUES] = {0};
  v[0] = -5; /* values may be negative */
  e[17 + 12 + 11] = -0.5;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v, e, FIXTURE_VALUES));
  assert_message_contains("std_errors[40] (row 2, pixel 11, bin 1) is -0.5; it must be finite and >= 0");
  e[40] = 0;
  e[16] = NaN;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v, e, FIXTURE_VALUES));
  assert_message_contains("std_errors[16] (row 1, pixel 0, bin 4) is nan");
  fixture_release(&f);
}

static void failed_set_values_changes_nothing(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES], e[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) v[i] = 1, e[i] = 2;
  assert_ok(hetinv_measurements_set_values(f.set, v, e, FIXTURE_VALUES));
  double v2[FIXTURE_VALUES], e2[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) v2[i] = 3, e2[i] = 4;
  e2[FIXTURE_VALUES - 1] = -1; /* the values are fine, the last error is not */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v2, e2, FIXTURE_VALUES));
  v2[0] = NaN;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_values(f.set, v2, NULL, FIXTURE_VALUES));
  const double *sv = hetinv_measurements_values(f.set), *se = hetinv_measurements_std_errors(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) assert_true(sv[i] == 1.0 && se[i] == 2.0);
  fixture_release(&f);
}

static void set_weights_copies_weights(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double w[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) w[i] = 0.5 * i; /* 0 is allowed */
  assert_ok(hetinv_measurements_set_weights(f.set, w, FIXTURE_VALUES));
  w[0] = 99;
  const double *sw = hetinv_measurements_weights(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) assert_true(sw[i] == 0.5 * i);
  fixture_release(&f);
}

static void set_weights_rejects_a_count_mismatch(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double w[FIXTURE_VALUES] = {0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_weights(f.set, w, 40));
  assert_message_contains("count is 40; the set has 41 values");
  fixture_release(&f);
}

static void set_weights_names_row_pixel_and_bin_of_a_bad_weight(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double w[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) w[i] = 1;
  w[12 + 2] = -1;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_weights(f.set, w, FIXTURE_VALUES));
  assert_message_contains("weights[14] (row 1, pixel 0, bin 2) is -1; it must be finite and >= 0");
  w[14] = 1;
  w[17 + 7] = Inf;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_weights(f.set, w, FIXTURE_VALUES));
  assert_message_contains("weights[24] (row 2, pixel 7, bin 0) is inf");
  /* Nothing changed. */
  const double *sw = hetinv_measurements_weights(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) assert_true(sw[i] == 1.0);
  fixture_release(&f);
}

static void set_mask_copies_the_mask(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  uint8_t k[FIXTURE_VALUES];
  for (int i = 0; i < FIXTURE_VALUES; ++i) k[i] = (uint8_t)(i % 3 == 0 ? 0 : 7);
  assert_ok(hetinv_measurements_set_mask(f.set, k, FIXTURE_VALUES));
  k[1] = 0;
  const uint8_t *sk = hetinv_measurements_mask(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) assert_int_equal(sk[i], i % 3 == 0 ? 0 : 7);
  fixture_release(&f);
}

static void set_mask_rejects_a_count_mismatch(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  uint8_t k[FIXTURE_VALUES + 1] = {0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_measurements_set_mask(f.set, k, FIXTURE_VALUES + 1));
  assert_message_contains("count is 42; the set has 41 values");
  const uint8_t *sk = hetinv_measurements_mask(f.set);
  for (int i = 0; i < FIXTURE_VALUES; ++i) assert_int_equal(sk[i], 1);
  fixture_release(&f);
}

static void setters_reject_null_arguments(void **state) {
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  double v[FIXTURE_VALUES] = {0};
  uint8_t k[FIXTURE_VALUES] = {0};
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_set_values(NULL, v, NULL, FIXTURE_VALUES));
  assert_message_contains("'set' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_set_values(f.set, NULL, v, FIXTURE_VALUES));
  assert_message_contains("'values' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_set_weights(NULL, v, FIXTURE_VALUES));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_set_weights(f.set, NULL, FIXTURE_VALUES));
  assert_message_contains("'weights' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_set_mask(NULL, k, FIXTURE_VALUES));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_measurements_set_mask(f.set, NULL, FIXTURE_VALUES));
  assert_message_contains("'mask' is NULL");
  fixture_release(&f);
}

static void queries_accept_null(void **state) {
  (void)state;
  assert_int_equal(hetinv_measurements_row_count(NULL), 0);
  assert_int_equal(hetinv_measurements_value_count(NULL), 0);
  assert_null(hetinv_measurements_values(NULL));
  assert_null(hetinv_measurements_std_errors(NULL));
  assert_null(hetinv_measurements_weights(NULL));
  assert_null(hetinv_measurements_mask(NULL));
}

static void destroy_accepts_null_and_clears_the_handle(void **state) {
  hetinv_measurements_destroy(NULL);
  hetinv_measurements_t *set = NULL;
  hetinv_measurements_destroy(&set);
  fixture_t f;
  fixture_init(*state, &f);
  fixture_add_rows(&f);
  hetinv_measurements_destroy(&f.set);
  assert_null(f.set);
  hetinv_measurements_destroy(&f.set);
  fixture_release(&f);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(new_set_is_empty),
      cmocka_unit_test(create_rejects_null_arguments),
      cmocka_unit_test(rows_follow_one_another),
      cmocka_unit_test(add_accepts_a_null_row_output),
      cmocka_unit_test(row_layout_accepts_null_outputs),
      cmocka_unit_test(row_layout_rejects_unknown_rows),
      cmocka_unit_test(new_rows_have_value_zero_weight_one_and_are_used),
      cmocka_unit_test(adding_rows_keeps_earlier_values),
      cmocka_unit_test(rows_may_share_sampling_functions),
      cmocka_unit_test(add_rejects_null_arguments),
      cmocka_unit_test(rows_from_media_with_different_boxes_are_rejected),
      cmocka_unit_test(rows_from_media_with_different_indices_are_rejected),
      cmocka_unit_test(first_row_must_not_mix_media),
      cmocka_unit_test(media_with_equal_box_and_indices_mix),
      cmocka_unit_test(media_whose_boxes_differ_only_in_the_sign_of_zero_mix),
      cmocka_unit_test(set_values_copies_values_and_errors),
      cmocka_unit_test(set_values_without_errors_resets_them_to_zero),
      cmocka_unit_test(set_values_rejects_a_count_mismatch),
      cmocka_unit_test(set_values_names_row_pixel_and_bin_of_a_non_finite_value),
      cmocka_unit_test(set_values_rejects_negative_or_non_finite_errors),
      cmocka_unit_test(failed_set_values_changes_nothing),
      cmocka_unit_test(set_weights_copies_weights),
      cmocka_unit_test(set_weights_rejects_a_count_mismatch),
      cmocka_unit_test(set_weights_names_row_pixel_and_bin_of_a_bad_weight),
      cmocka_unit_test(set_mask_copies_the_mask),
      cmocka_unit_test(set_mask_rejects_a_count_mismatch),
      cmocka_unit_test(setters_reject_null_arguments),
      cmocka_unit_test(queries_accept_null),
      cmocka_unit_test(destroy_accepts_null_and_clears_the_handle),
  };
  return cmocka_run_group_tests(tests, ht_context_setup, ht_context_teardown);
}
