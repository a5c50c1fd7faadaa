/* The medium: geometry, validation of every value, commit, clone. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

static const double unit_min[3] = {0, 0, 0};
static const double unit_max[3] = {10, 10, 10};

static hetinv_medium_t *make(hetinv_context_t *ctx, int32_t nx, int32_t ny, int32_t nz) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, unit_min, unit_max, (int32_t[]){nx, ny, nz}, &m));
  return m;
}

static void new_medium_is_empty_and_index_matched(void **state) {
  hetinv_medium_t *m = make(*state, 3, 4, 5);
  int32_t dims[3];
  assert_ok(hetinv_medium_get_dims(m, dims));
  assert_int_equal(dims[0], 3);
  assert_int_equal(dims[1], 4);
  assert_int_equal(dims[2], 5);
  assert_int_equal(hetinv_medium_voxel_count(m), 60);
  double eta, eta_out, a, s, g;
  assert_ok(hetinv_medium_get_ior(m, &eta, &eta_out));
  assert_true(eta == 1.0 && eta_out == 1.0);
  assert_ok(hetinv_medium_get_voxel(m, 2, 3, 4, &a, &s, &g));
  assert_true(a == 0.0 && s == 0.0 && g == 0.0);
  assert_false(hetinv_medium_is_committed(m));
  assert_ptr_equal(hetinv_medium_context(m), *state);
  hetinv_medium_destroy(&m);
  assert_null(m);
}

static void box_is_kept(void **state) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(*state, (double[]){-1, -2, -3}, (double[]){1, 2, 0.5},
                                 (int32_t[]){1, 1, 1}, &m));
  double lo[3], hi[3];
  assert_ok(hetinv_medium_get_box(m, lo, hi));
  assert_true(lo[0] == -1 && lo[1] == -2 && lo[2] == -3);
  assert_true(hi[0] == 1 && hi[1] == 2 && hi[2] == 0.5);
  assert_ok(hetinv_medium_get_box(m, NULL, NULL));
  hetinv_medium_destroy(&m);
}

static void voxel_order_is_x_fastest(void **state) {
  hetinv_medium_t *m = make(*state, 3, 4, 5);
  assert_ok(hetinv_medium_set_voxel(m, 1, 2, 3, 0.5, 2.0, 0.25));
  const double *sa = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A);
  const double *ss = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S);
  const double *g = hetinv_medium_grid(m, HETINV_PARAM_G);
  size_t k = 1 + 3 * (2 + 4 * 3);
  assert_true(sa[k] == 0.5 && ss[k] == 2.0 && g[k] == 0.25);
  assert_true(sa[k - 1] == 0.0 && sa[k + 1] == 0.0);
  hetinv_medium_destroy(&m);
}

static void set_grid_replaces_one_parameter(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 2);
  double v[8];
  for (int i = 0; i < 8; ++i) v[i] = 0.1 * i;
  assert_ok(hetinv_medium_set_grid(m, HETINV_PARAM_SIGMA_S, v, 8));
  double s;
  assert_ok(hetinv_medium_get_voxel(m, 1, 1, 1, NULL, &s, NULL));
  assert_true(s == v[7]);
  assert_true(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A)[7] == 0.0);
  hetinv_medium_destroy(&m);
}

static void fill_sets_every_voxel(void **state) {
  hetinv_medium_t *m = make(*state, 2, 3, 1);
  assert_ok(hetinv_medium_fill(m, 1.0, 10.0, 0.5));
  for (int i = 0; i < 6; ++i) {
    assert_true(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A)[i] == 1.0);
    assert_true(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[i] == 10.0);
    assert_true(hetinv_medium_grid(m, HETINV_PARAM_G)[i] == 0.5);
  }
  hetinv_medium_destroy(&m);
}

static void ior_is_set_and_validated(void **state) {
  hetinv_medium_t *m = make(*state, 1, 1, 1);
  assert_ok(hetinv_medium_set_ior(m, 1.3, 1.0));
  double eta;
  assert_ok(hetinv_medium_get_ior(m, &eta, NULL));
  assert_true(eta == 1.3);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_ior(m, 0.0, 1.0));
  assert_message_contains("eta (inside) is 0");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_ior(m, 1.3, (double)NAN));
  assert_message_contains("eta_out (outside) is nan");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_ior(m, (double)INFINITY, 1.0));
  /* Both finite and > 0, but a ratio that underflows to 0 (it tripped
   * Fresnel's assertion in a render) or no dielectric has. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_ior(m, 1e-200, 1e200));
  assert_message_contains("the relative index must be within [0.001, 1000]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_ior(m, 1.0, 1001.0));
  assert_ok(hetinv_medium_get_ior(m, &eta, NULL));
  assert_true(eta == 1.3); /* unchanged by the failures */
  assert_ok(hetinv_medium_set_ior(m, 1000.0, 1.0)); /* the limit itself */
  hetinv_medium_destroy(&m);
}

static void negative_sigma_names_the_voxel(void **state) {
  hetinv_medium_t *m = make(*state, 20, 5, 1);
  double v[100] = {0};
  v[12 + 20 * 4] = -0.3;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_set_grid(m, HETINV_PARAM_SIGMA_S, v, 100));
  assert_message_contains("sigma_s of voxel (12, 4, 0) is -0.3; it must be >= 0");
  assert_true(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[0] == 0.0);
  hetinv_medium_destroy(&m);
}

static void g_outside_open_interval_is_rejected(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 2);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_voxel(m, 1, 0, 1, 0, 1, 1.0));
  assert_message_contains("g of voxel (1, 0, 1) is 1; it must satisfy -1 < g < 1");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_voxel(m, 0, 0, 0, 0, 1, -1.0));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_fill(m, 0, 1, -1.5));
  assert_message_contains("g is -1.5");
  assert_ok(hetinv_medium_set_voxel(m, 0, 0, 0, 0, 1, -0.999));
  hetinv_medium_destroy(&m);
}

static void non_finite_values_are_rejected(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 2);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_voxel(m, 0, 1, 0, (double)NAN, 1, 0));
  assert_message_contains("sigma_a of voxel (0, 1, 0) is nan; it must be finite");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_fill(m, 0, (double)INFINITY, 0));
  assert_message_contains("sigma_s is inf; it must be finite");
  double v[8] = {0, 0, 0, 0, 0, 0, 0, -(double)INFINITY};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_set_grid(m, HETINV_PARAM_G, v, 8));
  assert_message_contains("g of voxel (1, 1, 1) is -inf");
  hetinv_medium_destroy(&m);
}

static void voxel_outside_grid_is_out_of_range(void **state) {
  hetinv_medium_t *m = make(*state, 2, 3, 4);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_medium_set_voxel(m, 2, 0, 0, 0, 0, 0));
  assert_message_contains("voxel (2, 0, 0) is outside the 2 x 3 x 4 grid");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_medium_set_voxel(m, 0, -1, 0, 0, 0, 0));
  assert_result(HETINV_ERROR_OUT_OF_RANGE,
                hetinv_medium_get_voxel(m, 0, 0, 4, NULL, NULL, NULL));
  hetinv_medium_destroy(&m);
}

static void wrong_grid_count_or_param_is_rejected(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 2);
  double v[9] = {0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_set_grid(m, HETINV_PARAM_SIGMA_A, v, 9));
  assert_message_contains("count is 9; the 2 x 2 x 2 grid has 8 voxels");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_medium_set_grid(m, 3, v, 8));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_medium_set_grid(m, -1, v, 8));
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_medium_set_grid(m, HETINV_PARAM_SIGMA_A, NULL, 8));
  assert_null(hetinv_medium_grid(m, 3));
  hetinv_medium_destroy(&m);
}

static void degenerate_box_is_rejected(void **state) {
  hetinv_medium_t *m = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(*state, (double[]){0, 0, 0}, (double[]){1, 0, 1},
                                     (int32_t[]){1, 1, 1}, &m));
  assert_null(m);
  assert_message_contains("the box along y is [0, 0]; box_min must be < box_max");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(*state, (double[]){0, 0, 2}, (double[]){1, 1, 1},
                                     (int32_t[]){1, 1, 1}, &m));
  assert_message_contains("box along z");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(*state, (double[]){0, 0, (double)NAN}, (double[]){1, 1, 1},
                                     (int32_t[]){1, 1, 1}, &m));
  assert_message_contains("must be finite");
}

static void non_positive_dims_are_rejected(void **state) {
  hetinv_medium_t *m = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(*state, unit_min, unit_max, (int32_t[]){1, 1, -7}, &m));
  assert_message_contains("dims[2] (nz) is -7; it must be > 0");
}

static void overflowing_dims_are_rejected(void **state) {
  hetinv_medium_t *m = NULL;
  /* 2^31-1 cubed overflows 64-bit size_t; 2^21 cubed fits but not times
   * 24 bytes; both are far beyond HETINV_MAX_VOXELS, checked first. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(*state, unit_min, unit_max,
                                     (int32_t[]){INT32_MAX, INT32_MAX, INT32_MAX}, &m));
  assert_message_contains("at most HETINV_MAX_VOXELS (16777216)");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(*state, unit_min, unit_max,
                                     (int32_t[]){1 << 21, 1 << 21, 1 << 21}, &m));
  assert_message_contains("dims is 2097152 x 2097152 x 2097152 voxels");
  assert_null(m);
}

static void null_arguments_are_rejected(void **state) {
  hetinv_medium_t *m = NULL;
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_medium_create(*state, unit_min, unit_max, (int32_t[]){1, 1, 1}, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_medium_create(NULL, unit_min, unit_max, (int32_t[]){1, 1, 1}, &m));
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_medium_create(*state, unit_min, unit_max, NULL, &m));
  assert_message_contains("'dims' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_fill(NULL, 0, 0, 0));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_set_ior(NULL, 1, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_commit(NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_get_dims(NULL, (int32_t[3]){0}));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_clone(NULL, &m));
  assert_int_equal(hetinv_medium_voxel_count(NULL), 0);
  assert_false(hetinv_medium_is_committed(NULL));
  hetinv_medium_destroy(NULL);
  hetinv_medium_destroy(&m);
}

static void committed_medium_is_immutable(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 2);
  assert_ok(hetinv_medium_commit(m));
  assert_ok(hetinv_medium_commit(m));
  assert_true(hetinv_medium_is_committed(m));
  double v[8] = {0};
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_medium_fill(m, 1, 1, 0));
  assert_message_contains("committed");
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_medium_set_voxel(m, 0, 0, 0, 1, 1, 0));
  assert_result(HETINV_ERROR_INVALID_STATE,
                hetinv_medium_set_grid(m, HETINV_PARAM_SIGMA_A, v, 8));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_medium_set_ior(m, 1.5, 1));
  hetinv_medium_destroy(&m);
}

static void clone_is_an_uncommitted_copy(void **state) {
  hetinv_medium_t *m = make(*state, 3, 1, 2);
  assert_ok(hetinv_medium_set_voxel(m, 2, 0, 1, 0.5, 3, -0.2));
  assert_ok(hetinv_medium_set_ior(m, 1.4, 1.1));
  assert_ok(hetinv_medium_commit(m));
  hetinv_medium_t *c = NULL;
  assert_ok(hetinv_medium_clone(m, &c));
  assert_false(hetinv_medium_is_committed(c));
  double a, s, g, eta, eta_out;
  assert_ok(hetinv_medium_get_voxel(c, 2, 0, 1, &a, &s, &g));
  assert_true(a == 0.5 && s == 3 && g == -0.2);
  assert_ok(hetinv_medium_get_ior(c, &eta, &eta_out));
  assert_true(eta == 1.4 && eta_out == 1.1);
  assert_ok(hetinv_medium_fill(c, 1, 1, 0));
  assert_ok(hetinv_medium_get_voxel(m, 2, 0, 1, &a, NULL, NULL));
  assert_true(a == 0.5); /* the original is untouched */
  hetinv_medium_destroy(&c);
  hetinv_medium_destroy(&m);
}

static void param_names_are_static(void **state) {
  (void)state;
  assert_string_equal(hetinv_param_name(HETINV_PARAM_SIGMA_A), "sigma_a");
  assert_string_equal(hetinv_param_name(HETINV_PARAM_SIGMA_S), "sigma_s");
  assert_string_equal(hetinv_param_name(HETINV_PARAM_G), "g");
  assert_string_equal(hetinv_param_name(17), "unknown");
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(new_medium_is_empty_and_index_matched),
      cmocka_unit_test(box_is_kept),
      cmocka_unit_test(voxel_order_is_x_fastest),
      cmocka_unit_test(set_grid_replaces_one_parameter),
      cmocka_unit_test(fill_sets_every_voxel),
      cmocka_unit_test(ior_is_set_and_validated),
      cmocka_unit_test(negative_sigma_names_the_voxel),
      cmocka_unit_test(g_outside_open_interval_is_rejected),
      cmocka_unit_test(non_finite_values_are_rejected),
      cmocka_unit_test(voxel_outside_grid_is_out_of_range),
      cmocka_unit_test(wrong_grid_count_or_param_is_rejected),
      cmocka_unit_test(degenerate_box_is_rejected),
      cmocka_unit_test(non_positive_dims_are_rejected),
      cmocka_unit_test(overflowing_dims_are_rejected),
      cmocka_unit_test(null_arguments_are_rejected),
      cmocka_unit_test(committed_medium_is_immutable),
      cmocka_unit_test(clone_is_an_uncommitted_copy),
      cmocka_unit_test(param_names_are_static),
  };
  return cmocka_run_group_tests(tests, ht_context_setup, ht_context_teardown);
}
