/* Synthetic volumes: Gaussian mixtures (exact range, constant axis,
 * determinism, smoothness) and smoke plumes (range, smoothness, shape,
 * determinism), and every bad spec with its exact code and message. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

static hetinv_medium_t *make_in(hetinv_context_t *ctx, int32_t nx, int32_t ny, int32_t nz) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){-1, 0, 2}, (double[]){1, 3, 4},
                                 (int32_t[]){nx, ny, nz}, &m));
  return m;
}

static void range_of(const hetinv_medium_t *m, hetinv_param_t p, double *lo, double *hi) {
  const double *v = hetinv_medium_grid(m, p);
  *lo = (double)INFINITY, *hi = -(double)INFINITY;
  for (size_t i = 0; i < hetinv_medium_voxel_count(m); ++i) {
    *lo = fmin(*lo, v[i]);
    *hi = fmax(*hi, v[i]);
  }
}

/* Largest difference between face neighbours, as a fraction of hi − lo. */
static double max_step(const hetinv_medium_t *m, hetinv_param_t p, double lo, double hi) {
  int32_t d[3];
  assert_ok(hetinv_medium_get_dims(m, d));
  const double *v = hetinv_medium_grid(m, p);
  double step = 0.0;
  for (int32_t z = 0; z < d[2]; ++z) {
    for (int32_t y = 0; y < d[1]; ++y) {
      for (int32_t x = 0; x < d[0]; ++x) {
        size_t i = (size_t)x + (size_t)d[0] * ((size_t)y + (size_t)d[1] * (size_t)z);
        if (x + 1 < d[0]) step = fmax(step, fabs(v[i + 1] - v[i]));
        if (y + 1 < d[1]) step = fmax(step, fabs(v[i + (size_t)d[0]] - v[i]));
        if (z + 1 < d[2]) step = fmax(step, fabs(v[i + (size_t)d[0] * (size_t)d[1]] - v[i]));
      }
    }
  }
  return step / (hi - lo);
}

static int media_equal(const hetinv_medium_t *a, const hetinv_medium_t *b) {
  size_t n = hetinv_medium_voxel_count(a);
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    if (memcmp(hetinv_medium_grid(a, p), hetinv_medium_grid(b, p), n * sizeof(double)) != 0) {
      return 0;
    }
  }
  return 1;
}

/* ------------------------------------------------------------------------ */
/* Gaussian mixtures. */

static void mixture_spans_lo_to_hi_exactly(void **state) {
  hetinv_mixture_spec_t spec;
  hetinv_mixture_spec_default(&spec);
  assert_true(spec.size == sizeof spec && spec.components == 2 && spec.constant_axis == -1);
  spec.lo[0] = 0.1, spec.hi[0] = 0.3; /* lo + (hi − lo) is not hi in floating point */
  spec.lo[2] = -0.7, spec.hi[2] = 0.95;
  for (uint64_t seed = 0; seed < 8; ++seed) {
    spec.seed = seed;
    spec.components = (int32_t)(1 + seed % 4);
    hetinv_medium_t *m = make_in(*state, 16, 12, 10);
    assert_ok(hetinv_volume_gaussian_mixture(m, &spec));
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      double lo, hi;
      range_of(m, p, &lo, &hi);
      assert_true(lo == spec.lo[p]);
      assert_true(hi == spec.hi[p]);
    }
    hetinv_medium_destroy(&m);
  }
}

static void mixture_with_constant_axis_is_a_cross_section(void **state) {
  hetinv_mixture_spec_t spec;
  hetinv_mixture_spec_default(&spec);
  spec.seed = 9;
  for (int32_t axis = 0; axis < 3; ++axis) {
    spec.constant_axis = axis;
    hetinv_medium_t *m = make_in(*state, 8, 9, 10);
    assert_ok(hetinv_volume_gaussian_mixture(m, &spec));
    int32_t d[3] = {8, 9, 10};
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      for (int32_t z = 0; z < d[2]; ++z) {
        for (int32_t y = 0; y < d[1]; ++y) {
          for (int32_t x = 0; x < d[0]; ++x) {
            int32_t at[3] = {x, y, z}, first[3] = {x, y, z};
            first[axis] = 0;
            double v[3], v0[3];
            assert_ok(hetinv_medium_get_voxel(m, at[0], at[1], at[2], &v[0], &v[1], &v[2]));
            assert_ok(hetinv_medium_get_voxel(m, first[0], first[1], first[2], &v0[0], &v0[1],
                                              &v0[2]));
            assert_true(v[p] == v0[p]);
          }
        }
      }
      double lo, hi;
      range_of(m, p, &lo, &hi);
      assert_true(lo == spec.lo[p] && hi == spec.hi[p]); /* it varies along the other two */
    }
    hetinv_medium_destroy(&m);
  }
}

static void mixture_is_deterministic_and_seeds_differ(void **state) {
  hetinv_mixture_spec_t spec;
  hetinv_mixture_spec_default(&spec);
  spec.seed = 1234;
  hetinv_medium_t *a = make_in(*state, 10, 10, 10), *b = make_in(*state, 10, 10, 10);
  assert_ok(hetinv_volume_gaussian_mixture(a, &spec));
  assert_ok(hetinv_volume_gaussian_mixture(b, &spec));
  assert_true(media_equal(a, b));
  /* Independent of the thread count. */
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  hetinv_context_t *one = NULL;
  assert_ok(hetinv_context_create(&init, &one));
  hetinv_medium_t *c = make_in(one, 10, 10, 10);
  assert_ok(hetinv_volume_gaussian_mixture(c, &spec));
  assert_true(media_equal(a, c));
  /* Another seed, another volume: every parameter differs almost everywhere. */
  spec.seed = 1235;
  assert_ok(hetinv_volume_gaussian_mixture(b, &spec));
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    size_t same = 0;
    for (size_t i = 0; i < 1000; ++i) same += hetinv_medium_grid(a, p)[i] == hetinv_medium_grid(b, p)[i];
    assert_true(same < 10);
  }
  hetinv_medium_destroy(&a);
  hetinv_medium_destroy(&b);
  hetinv_medium_destroy(&c);
  hetinv_context_destroy(&one);
}

static void mixture_is_smooth(void **state) {
  /* Widths >= 0.15 L: on a 128² cross-section no step between neighbours
   * exceeds a few percent of the range, and halving the voxels about halves
   * the largest step (a Lipschitz field, not noise). */
  hetinv_mixture_spec_t spec;
  hetinv_mixture_spec_default(&spec);
  spec.constant_axis = 2;
  for (uint64_t seed = 0; seed < 4; ++seed) {
    spec.seed = seed;
    hetinv_medium_t *fine = make_in(*state, 128, 128, 1), *coarse = make_in(*state, 64, 64, 1);
    assert_ok(hetinv_volume_gaussian_mixture(fine, &spec));
    assert_ok(hetinv_volume_gaussian_mixture(coarse, &spec));
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      double s_fine = max_step(fine, p, spec.lo[p], spec.hi[p]);
      double s_coarse = max_step(coarse, p, spec.lo[p], spec.hi[p]);
      if (!(s_fine < 0.08 && s_fine < 0.6 * s_coarse)) {
        print_error("seed %llu, %s: largest steps %.4f (128) and %.4f (64) of the range\n",
                    (unsigned long long)seed, hetinv_param_name(p), s_fine, s_coarse);
        fail();
      }
    }
    hetinv_medium_destroy(&fine);
    hetinv_medium_destroy(&coarse);
  }
}

static void mixture_constant_field_takes_the_midpoint(void **state) {
  hetinv_mixture_spec_t spec;
  hetinv_mixture_spec_default(&spec);
  hetinv_medium_t *m = make_in(*state, 1, 1, 1);
  assert_ok(hetinv_volume_gaussian_mixture(m, &spec));
  double v[3];
  assert_ok(hetinv_medium_get_voxel(m, 0, 0, 0, &v[0], &v[1], &v[2]));
  for (int p = 0; p < 3; ++p) assert_true(v[p] == 0.5 * (spec.lo[p] + spec.hi[p]));
  hetinv_medium_destroy(&m);
  /* lo == hi: every voxel holds it. */
  spec.lo[1] = spec.hi[1] = 2.5;
  m = make_in(*state, 5, 4, 3);
  assert_ok(hetinv_volume_gaussian_mixture(m, &spec));
  for (size_t i = 0; i < 60; ++i) assert_true(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[i] == 2.5);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* Smoke. */

static void smoke_stays_in_range_and_reaches_the_densest_value(void **state) {
  hetinv_smoke_spec_t spec;
  hetinv_smoke_spec_default(&spec);
  assert_true(spec.size == sizeof spec && spec.octaves == 3 && spec.feature_size == 0.25);
  for (uint64_t seed = 0; seed < 3; ++seed) {
    spec.seed = seed;
    hetinv_medium_t *m = make_in(*state, 24, 32, 24);
    assert_ok(hetinv_volume_smoke(m, &spec));
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      double lo, hi;
      range_of(m, p, &lo, &hi);
      assert_true(lo >= spec.lo[p] && hi <= spec.hi[p]);
      assert_true(hi - lo > 0.2 * (spec.hi[p] - spec.lo[p])); /* it does vary */
      if (p == HETINV_PARAM_SIGMA_S) assert_true(hi == spec.hi[p]);
    }
    hetinv_medium_destroy(&m);
  }
}

static void smoke_is_a_plume_around_the_vertical_axis(void **state) {
  /* The densest voxels are near the box's vertical centre line, the walls
   * at x = ±1 nearly empty: mean σs of the central third of x well above
   * that of the outer sixths. */
  hetinv_smoke_spec_t spec;
  hetinv_smoke_spec_default(&spec);
  hetinv_medium_t *m = make_in(*state, 24, 24, 24);
  for (uint64_t seed = 0; seed < 3; ++seed) {
    spec.seed = seed;
    assert_ok(hetinv_volume_smoke(m, &spec));
    const double *ss = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S);
    double centre = 0.0, outer = 0.0;
    for (size_t i = 0; i < 24 * 24 * 24; ++i) {
      size_t x = i % 24;
      if (x >= 8 && x < 16) centre += ss[i];
      if (x < 4 || x >= 20) outer += ss[i];
    }
    assert_true(centre / 8.0 > 3.0 * (outer / 8.0));
  }
  hetinv_medium_destroy(&m);
}

/* Steps halve with the voxel size (Lipschitz, not noise); on 48³ the
 * narrowest part of the column (radius ~3 voxels) gives the largest, about
 * h/(r·√e) of the peak. */
static void smoke_is_smooth(void **state) {
  hetinv_smoke_spec_t spec;
  hetinv_smoke_spec_default(&spec);
  spec.octaves = 2; /* finest lattice spacing L/8: 6 voxels at 48³ */
  for (uint64_t seed = 0; seed < 2; ++seed) {
    spec.seed = seed;
    hetinv_medium_t *fine = make_in(*state, 48, 48, 48), *coarse = make_in(*state, 24, 24, 24);
    assert_ok(hetinv_volume_smoke(fine, &spec));
    assert_ok(hetinv_volume_smoke(coarse, &spec));
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      double s_fine = max_step(fine, p, spec.lo[p], spec.hi[p]);
      double s_coarse = max_step(coarse, p, spec.lo[p], spec.hi[p]);
      if (!(s_fine < 0.25 && s_fine < 0.7 * s_coarse)) {
        print_error("seed %llu, %s: largest steps %.4f (48) and %.4f (24) of the range\n",
                    (unsigned long long)seed, hetinv_param_name(p), s_fine, s_coarse);
        fail();
      }
    }
    hetinv_medium_destroy(&fine);
    hetinv_medium_destroy(&coarse);
  }
}

static void smoke_is_deterministic_and_seeds_differ(void **state) {
  hetinv_smoke_spec_t spec;
  hetinv_smoke_spec_default(&spec);
  spec.seed = 77;
  spec.octaves = HETINV_SMOKE_OCTAVES_MAX;
  spec.feature_size = HETINV_SMOKE_FEATURE_MIN; /* the largest lattice */
  hetinv_medium_t *a = make_in(*state, 12, 14, 10), *b = make_in(*state, 12, 14, 10);
  assert_ok(hetinv_volume_smoke(a, &spec));
  assert_ok(hetinv_volume_smoke(b, &spec));
  assert_true(media_equal(a, b));
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  hetinv_context_t *one = NULL;
  assert_ok(hetinv_context_create(&init, &one));
  hetinv_medium_t *c = make_in(one, 12, 14, 10);
  assert_ok(hetinv_volume_smoke(c, &spec));
  assert_true(media_equal(a, c));
  spec.seed = 78;
  assert_ok(hetinv_volume_smoke(b, &spec));
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    size_t same = 0;
    for (size_t i = 0; i < 12 * 14 * 10; ++i) {
      same += hetinv_medium_grid(a, p)[i] == hetinv_medium_grid(b, p)[i];
    }
    assert_true(same < 100);
  }
  hetinv_medium_destroy(&a);
  hetinv_medium_destroy(&b);
  hetinv_medium_destroy(&c);
  hetinv_context_destroy(&one);
}

/* ------------------------------------------------------------------------ */
/* Errors. */

/* The medium holds the values of `fill` after a failed call. */
static void assert_untouched(const hetinv_medium_t *m) {
  for (size_t i = 0; i < hetinv_medium_voxel_count(m); ++i) {
    assert_true(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A)[i] == 0.25);
    assert_true(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[i] == 3.0);
    assert_true(hetinv_medium_grid(m, HETINV_PARAM_G)[i] == 0.5);
  }
}

#define EXPECT_MIXTURE(code, text) \
  do { \
    assert_result((code), hetinv_volume_gaussian_mixture(m, &s)); \
    assert_message_contains("hetinv_volume_gaussian_mixture: "); \
    assert_message_contains(text); \
    assert_untouched(m); \
    s = ok; \
  } while (0)

static void bad_mixture_specs_fail_with_precise_messages(void **state) {
  hetinv_mixture_spec_t ok, s;
  hetinv_mixture_spec_default(&ok);
  hetinv_mixture_spec_default(NULL); /* a no-op */
  s = ok;
  hetinv_medium_t *m = make_in(*state, 4, 4, 4);
  assert_ok(hetinv_medium_fill(m, 0.25, 3.0, 0.5));

  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_volume_gaussian_mixture(NULL, &ok));
  assert_message_contains("'medium' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_volume_gaussian_mixture(m, NULL));
  assert_message_contains("'spec' is NULL");

  s.size = 4;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->size is 4; it must be at least");
  s.lo[0] = 0.6, s.hi[0] = 0.5;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT,
                 "spec->lo[0] (sigma_a) is 0.6 and spec->hi[0] is 0.5; lo must be <= hi");
  s.lo[1] = -0.5;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->lo[1] (sigma_s) is -0.5; it must be >= 0");
  s.hi[1] = (double)INFINITY;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->hi[1] (sigma_s) is inf; it must be finite");
  s.hi[2] = 1.0;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->hi[2] (g) is 1; it must satisfy -1 < g < 1");
  s.lo[2] = -1.0;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->lo[2] (g) is -1; it must satisfy -1 < g < 1");
  s.components = 0;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->components is 0; it must be in [1, 16]");
  s.components = 17;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->components is 17; it must be in [1, 16]");
  s.min_width = 0.0;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->min_width is 0; it must be finite and > 0");
  s.min_width = -0.1;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->min_width is -0.1;");
  s.max_width = 0.1; /* below min_width 0.15 */
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT,
                 "spec->max_width is 0.1; it must be finite and >= spec->min_width (0.15)");
  s.max_width = (double)NAN;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->max_width is nan");
  s.constant_axis = 3;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->constant_axis is 3; it must be -1 (3D), 0, 1 or 2");
  s.constant_axis = -2;
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_ARGUMENT, "spec->constant_axis is -2");

  assert_ok(hetinv_medium_commit(m));
  EXPECT_MIXTURE(HETINV_ERROR_INVALID_STATE, "the medium is committed");
  hetinv_medium_destroy(&m);
}

#define EXPECT_SMOKE(code, text) \
  do { \
    assert_result((code), hetinv_volume_smoke(m, &s)); \
    assert_message_contains("hetinv_volume_smoke: "); \
    assert_message_contains(text); \
    assert_untouched(m); \
    s = ok; \
  } while (0)

static void bad_smoke_specs_fail_with_precise_messages(void **state) {
  hetinv_smoke_spec_t ok, s;
  hetinv_smoke_spec_default(&ok);
  hetinv_smoke_spec_default(NULL); /* a no-op */
  s = ok;
  hetinv_medium_t *m = make_in(*state, 4, 4, 4);
  assert_ok(hetinv_medium_fill(m, 0.25, 3.0, 0.5));

  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_volume_smoke(NULL, &ok));
  assert_message_contains("'medium' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_volume_smoke(m, NULL));
  assert_message_contains("'spec' is NULL");

  s.size = 0;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->size is 0; it must be at least");
  s.lo[1] = 30.0;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT,
               "spec->lo[1] (sigma_s) is 30 and spec->hi[1] is 20; lo must be <= hi");
  s.hi[0] = -1.0;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->hi[0] (sigma_a) is -1; it must be >= 0");
  s.lo[2] = -1.5;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->lo[2] (g) is -1.5; it must satisfy -1 < g < 1");
  s.octaves = 0;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->octaves is 0; it must be in [1, 6]");
  s.octaves = 7;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->octaves is 7; it must be in [1, 6]");
  s.feature_size = 0.01;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->feature_size is 0.01; it must be in [0.02, 1]");
  s.feature_size = 1.5;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->feature_size is 1.5;");
  s.feature_size = (double)NAN;
  EXPECT_SMOKE(HETINV_ERROR_INVALID_ARGUMENT, "spec->feature_size is nan;");

  assert_ok(hetinv_medium_commit(m));
  EXPECT_SMOKE(HETINV_ERROR_INVALID_STATE, "the medium is committed");
  hetinv_medium_destroy(&m);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(mixture_spans_lo_to_hi_exactly),
      cmocka_unit_test(mixture_with_constant_axis_is_a_cross_section),
      cmocka_unit_test(mixture_is_deterministic_and_seeds_differ),
      cmocka_unit_test(mixture_is_smooth),
      cmocka_unit_test(mixture_constant_field_takes_the_midpoint),
      cmocka_unit_test(smoke_stays_in_range_and_reaches_the_densest_value),
      cmocka_unit_test(smoke_is_a_plume_around_the_vertical_axis),
      cmocka_unit_test(smoke_is_smooth),
      cmocka_unit_test(smoke_is_deterministic_and_seeds_differ),
      cmocka_unit_test(bad_mixture_specs_fail_with_precise_messages),
      cmocka_unit_test(bad_smoke_specs_fail_with_precise_messages),
  };
  return cmocka_run_group_tests(tests, ht_context_setup, ht_context_teardown);
}
