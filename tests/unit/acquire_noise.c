/* Sensor noise (hetinv_noise_apply): Poisson moments and distribution,
 * read noise, saturation, automatic exposure, standard errors, determinism
 * and order independence, and every error path.
 *
 * Statistical checks are z-tests with |z| < 5 (a false alarm about once in
 * 1.7 million runs per check). They draw from the seed test_seed(), which
 * HETINV_TEST_SEED overrides; a failure prints it. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

static uint64_t test_seed(void) {
  const char *s = getenv("HETINV_TEST_SEED");
  return s != NULL ? strtoull(s, NULL, 0) : UINT64_C(0x13198a2e03707344);
}

#define Z_LIMIT 5.0

/* Fails, printing the seed, if |z| >= Z_LIMIT. */
#define assert_z(z, what, seed) \
  do { \
    double z_ = (z); \
    if (!(fabs(z_) < Z_LIMIT)) { \
      print_error("seed %#llx: %s is off by %.2f standard errors\n", (unsigned long long)(seed), \
                  (what), z_); \
      fail(); \
    } \
  } while (0)

/* A model measuring electrons directly: exposure 1, no read noise, a full
 * well far above every test's counts. */
static hetinv_noise_model_t counting_model(uint64_t seed) {
  hetinv_noise_model_t m;
  hetinv_noise_model_default(&m);
  m.exposure = 1.0;
  m.read_noise = 0.0;
  m.full_well = HETINV_NOISE_FULL_WELL_MAX;
  m.seed = seed;
  return m;
}

static double *filled(size_t n, double v) {
  double *a = malloc(n * sizeof *a);
  assert_non_null(a);
  for (size_t i = 0; i < n; ++i) a[i] = v;
  return a;
}

/* Sample mean and variance of x - shift (the shift keeps large means exact). */
static void moments(const double *x, size_t n, double shift, double *mean, double *var) {
  double s = 0.0, s2 = 0.0;
  for (size_t i = 0; i < n; ++i) s += x[i] - shift;
  double m = s / (double)n;
  for (size_t i = 0; i < n; ++i) s2 += (x[i] - shift - m) * (x[i] - shift - m);
  *mean = m + shift;
  *var = s2 / (double)(n - 1);
}

/* ------------------------------------------------------------------------ */
/* Poisson counts. */

static void poisson_mean_and_variance_equal_lambda(void **state) {
  const uint64_t seed = test_seed();
  const double lambdas[] = {0.5, 3.0, 25.0, 1000.0, 1e6, 1e12};
  const size_t n = 100000;
  double *out = malloc(n * sizeof *out);
  for (size_t l = 0; l < sizeof lambdas / sizeof lambdas[0]; ++l) {
    const double lambda = lambdas[l];
    hetinv_noise_model_t m = counting_model(seed + l);
    double *clean = filled(n, lambda);
    assert_ok(hetinv_noise_apply(*state, &m, clean, out, NULL, n, NULL));
    for (size_t i = 0; i < n; ++i) assert_true(out[i] >= 0.0 && out[i] == floor(out[i]));
    double mean, var;
    moments(out, n, lambda, &mean, &var);
    /* Var(mean) = λ/n; Var(s²) ≈ (μ4 − σ⁴)/n = (λ + 2λ²)/n for Poisson. */
    char what[64];
    snprintf(what, sizeof what, "the mean at lambda %g", lambda);
    assert_z((mean - lambda) / sqrt(lambda / (double)n), what, seed + l);
    snprintf(what, sizeof what, "the variance at lambda %g", lambda);
    assert_z((var - lambda) / sqrt((lambda + 2.0 * lambda * lambda) / (double)n), what, seed + l);
    free(clean);
  }
  free(out);
}

/* Pearson's χ² against the Poisson pmf, over the counts whose expected
 * number is >= 5 and the two tails lumped; z = (χ² − df)/√(2 df). */
static void poisson_histogram_matches_pmf(void **state) {
  const uint64_t seed = test_seed();
  const double lambdas[] = {3.0, 9.5, 10.0, 25.0, 150.0};
  const size_t n = 200000;
  double *out = malloc(n * sizeof *out);
  for (size_t l = 0; l < sizeof lambdas / sizeof lambdas[0]; ++l) {
    const double lambda = lambdas[l];
    hetinv_noise_model_t m = counting_model(seed ^ (0x100 + l));
    double *clean = filled(n, lambda);
    assert_ok(hetinv_noise_apply(*state, &m, clean, out, NULL, n, NULL));
    int kmax = (int)(lambda + 12.0 * sqrt(lambda) + 20.0);
    double *count = calloc((size_t)kmax + 1, sizeof *count);
    for (size_t i = 0; i < n; ++i) count[out[i] > kmax ? kmax : (int)out[i]] += 1.0;
    /* Bins [0, lo], lo+1, ..., hi-1, [hi, ∞) with expected counts >= 5. */
    double expect_below = 0.0, seen_below = 0.0, chi2 = 0.0, cdf = 0.0;
    int bins = 0, k = 0;
    for (; k < kmax; ++k) {
      double e = (double)n * exp(-lambda + k * log(lambda) - lgamma(k + 1.0));
      cdf += e;
      expect_below += e;
      seen_below += count[k];
      if (expect_below >= 5.0) {
        chi2 += (seen_below - expect_below) * (seen_below - expect_below) / expect_below;
        ++bins;
        expect_below = seen_below = 0.0;
      }
      if ((double)n - cdf < 5.0) break;
    }
    double seen_tail = 0.0;
    for (int j = k + 1; j <= kmax; ++j) seen_tail += count[j];
    double expect_tail = (double)n - cdf + expect_below;
    seen_tail += seen_below;
    if (expect_tail > 0.0) {
      chi2 += (seen_tail - expect_tail) * (seen_tail - expect_tail) / expect_tail;
      ++bins;
    }
    double df = bins - 1;
    char what[64];
    snprintf(what, sizeof what, "chi-square (%d bins) at lambda %g", bins, lambda);
    assert_true(bins >= 5);
    assert_z((chi2 - df) / sqrt(2.0 * df), what, seed ^ (0x100 + l));
    free(count);
    free(clean);
  }
  free(out);
}

static void zero_lambda_gives_exactly_zero(void **state) {
  hetinv_noise_model_t m = counting_model(1);
  double clean[64] = {0}, out[64], err[64];
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, err, 64, NULL));
  for (int i = 0; i < 64; ++i) {
    assert_true(out[i] == 0.0);
    assert_true(err[i] == 0.0);
  }
}

/* ------------------------------------------------------------------------ */
/* Read noise, saturation, exposure, standard errors. */

static void read_noise_variance_adds_to_poisson(void **state) {
  const uint64_t seed = test_seed();
  const size_t n = 100000;
  hetinv_noise_model_t m = counting_model(seed);
  m.read_noise = 10.0;
  double *clean = filled(n, 100.0), *out = malloc(n * sizeof *out);
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, NULL, n, NULL));
  double mean, var, total = 200.0; /* λ + r² */
  moments(out, n, 100.0, &mean, &var);
  /* Fourth central moment of Poisson + Normal: λ + 3λ² + 6λr² + 3r⁴ = 3·total² + λ. */
  assert_z((mean - 100.0) / sqrt(total / (double)n), "the mean with read noise", seed);
  assert_z((var - total) / sqrt((2.0 * total * total + 100.0) / (double)n),
           "the variance with read noise", seed);
  free(clean);
  free(out);
}

static void negative_values_are_kept_so_dark_pixels_stay_unbiased(void **state) {
  const uint64_t seed = test_seed();
  const size_t n = 100000;
  hetinv_noise_model_t m = counting_model(seed + 7);
  m.read_noise = 5.0;
  double *clean = filled(n, 0.0), *out = malloc(n * sizeof *out);
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, NULL, n, NULL));
  size_t negative = 0;
  for (size_t i = 0; i < n; ++i) negative += out[i] < 0.0;
  assert_true(negative > n / 3 && negative < 2 * n / 3); /* about half */
  double mean, var;
  moments(out, n, 0.0, &mean, &var);
  assert_z(mean / sqrt(25.0 / (double)n), "the mean of a dark value", seed + 7);
  free(clean);
  free(out);
}

/* A read noise the model allows whose square overflows (1e300 electrons):
 * the standard error is read_noise / exposure, finite (it came back inf). */
static void huge_read_noise_gives_a_finite_std_error(void **state) {
  hetinv_noise_model_t m = counting_model(test_seed());
  m.read_noise = 1e300;
  double clean[2] = {0.0, 5.0}, out[2], se[2];
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, se, 2, NULL));
  for (int i = 0; i < 2; ++i) assert_true(fabs(se[i] / 1e300 - 1.0) < 1e-12);
}

static void read_noise_leaves_the_photon_counts_unchanged(void **state) {
  const uint64_t seed = test_seed();
  const size_t n = 50000;
  hetinv_noise_model_t m = counting_model(seed);
  double *clean = filled(n, 40.0), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
  assert_ok(hetinv_noise_apply(*state, &m, clean, a, NULL, n, NULL));
  m.read_noise = 3.0;
  assert_ok(hetinv_noise_apply(*state, &m, clean, b, NULL, n, NULL));
  /* b − a is the read noise alone: Normal(0, 9). */
  for (size_t i = 0; i < n; ++i) b[i] -= a[i];
  double mean, var;
  moments(b, n, 0.0, &mean, &var);
  assert_z(mean / sqrt(9.0 / (double)n), "the mean of the read noise", seed);
  assert_z((var - 9.0) / sqrt(2.0 * 81.0 / (double)n), "the variance of the read noise", seed);
  free(clean);
  free(a);
  free(b);
}

static void saturation_clamps_at_the_full_well(void **state) {
  const size_t n = 10000;
  hetinv_noise_model_t m = counting_model(3);
  m.full_well = 1000.0;
  m.read_noise = 5.0;
  m.exposure = 4.0; /* 250 units of value fill the well */
  double *clean = filled(n, 5000.0), *out = malloc(n * sizeof *out);
  double *err = malloc(n * sizeof *err);
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, err, n, NULL));
  for (size_t i = 0; i < n; ++i) assert_true(out[i] == 250.0);
  /* Just below the well: some values clip, none exceed it. */
  for (size_t i = 0; i < n; ++i) clean[i] = 990.0 / 4.0;
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, err, n, NULL));
  size_t clipped = 0;
  for (size_t i = 0; i < n; ++i) {
    assert_true(out[i] <= 250.0);
    clipped += out[i] == 250.0;
  }
  assert_true(clipped > n / 10 && clipped < n);
  /* Means far beyond anything samplable saturate too. */
  clean[0] = 1e300;
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, err, 1, NULL));
  assert_true(out[0] == 250.0);
  free(clean);
  free(out);
  free(err);
}

static void automatic_exposure_maps_the_largest_value_to_auto_level(void **state) {
  const uint64_t seed = test_seed();
  const size_t n = 40000;
  hetinv_noise_model_t m;
  hetinv_noise_model_default(&m); /* exposure 0: automatic */
  m.seed = seed;
  assert_true(m.exposure == 0.0 && m.full_well == 20000.0 && m.auto_level == 0.9);
  double *clean = malloc(n * sizeof *clean), *out = malloc(n * sizeof *out);
  for (size_t i = 0; i < n; ++i) clean[i] = i % 2 ? 2.0 : 0.5;
  double exposure = -1.0;
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, NULL, n, &exposure));
  assert_true(exposure == 9000.0); /* 0.9 · 20000 / 2 */
  /* The values at 2 hold 18000 ± √(18000 + 25) electrons on average. */
  double s = 0.0;
  for (size_t i = 1; i < n; i += 2) s += out[i];
  double mean = s / (double)(n / 2);
  assert_z((mean - 2.0) / (sqrt(18000.0 + 25.0) / 9000.0 / sqrt((double)(n / 2))),
           "the mean under automatic exposure", seed);
  m.auto_level = 0.5;
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, NULL, n, &exposure));
  assert_true(exposure == 5000.0);
  free(clean);
  free(out);
}

static void std_errors_are_the_model_deviation_at_the_measurement(void **state) {
  const size_t n = 2000;
  hetinv_noise_model_t m;
  hetinv_noise_model_default(&m);
  m.exposure = 50.0;
  m.read_noise = 4.0;
  m.seed = 11;
  double *clean = malloc(n * sizeof *clean), *out = malloc(n * sizeof *out);
  double *err = malloc(n * sizeof *err);
  for (size_t i = 0; i < n; ++i) clean[i] = 0.01 * (double)(i % 300);
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, err, n, NULL));
  for (size_t i = 0; i < n; ++i) {
    double e = out[i] * 50.0;
    double expect = sqrt(fmax(e, 0.0) + 16.0) / 50.0;
    assert_true(fabs(err[i] - expect) <= 1e-12 * expect);
  }
  free(clean);
  free(out);
  free(err);
}

/* ------------------------------------------------------------------------ */
/* Determinism. */

static double *varied_clean(size_t n) {
  double *c = malloc(n * sizeof *c);
  for (size_t i = 0; i < n; ++i) c[i] = (double)((i * 7919) % 1000) * 0.37; /* 0 .. 370 */
  return c;
}

static void same_seed_same_bits_other_seed_other_values(void **state) {
  const size_t n = 3000;
  hetinv_noise_model_t m;
  hetinv_noise_model_default(&m);
  m.seed = 42;
  double *clean = varied_clean(n), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
  double *ea = malloc(n * sizeof *ea), *eb = malloc(n * sizeof *eb);
  assert_ok(hetinv_noise_apply(*state, &m, clean, a, ea, n, NULL));
  assert_ok(hetinv_noise_apply(*state, &m, clean, b, eb, n, NULL));
  assert_memory_equal(a, b, n * sizeof *a);
  assert_memory_equal(ea, eb, n * sizeof *ea);
  m.seed = 43;
  assert_ok(hetinv_noise_apply(*state, &m, clean, b, NULL, n, NULL));
  size_t same = 0;
  for (size_t i = 0; i < n; ++i) same += a[i] == b[i];
  assert_true(same < n / 10);
  free(clean);
  free(a);
  free(b);
  free(ea);
  free(eb);
}

static void chunks_with_first_index_match_one_call(void **state) {
  const size_t n = 1000;
  hetinv_noise_model_t m;
  hetinv_noise_model_default(&m);
  m.exposure = 30.0; /* fixed: automatic exposure would depend on each chunk's maximum */
  m.seed = 5;
  double *clean = varied_clean(n), *whole = malloc(n * sizeof *whole);
  double *part = malloc(n * sizeof *part);
  assert_ok(hetinv_noise_apply(*state, &m, clean, whole, NULL, n, NULL));
  const size_t cut[] = {0, 1, 300, 301, 777, 1000};
  for (size_t c = 0; c + 1 < sizeof cut / sizeof cut[0]; ++c) {
    m.first_index = cut[c];
    assert_ok(hetinv_noise_apply(*state, &m, clean + cut[c], part + cut[c], NULL,
                                 cut[c + 1] - cut[c], NULL));
  }
  assert_memory_equal(whole, part, n * sizeof *whole);
  /* Keys are indices: value i's noise does not depend on the other values. */
  double single;
  m.first_index = 500;
  assert_ok(hetinv_noise_apply(*state, &m, clean + 500, &single, NULL, 1, NULL));
  assert_true(single == whole[500]);
  free(clean);
  free(whole);
  free(part);
}

static void thread_count_does_not_change_the_values(void **state) {
  (void)state;
  const size_t n = 20000; /* enough to run in parallel */
  hetinv_noise_model_t m;
  hetinv_noise_model_default(&m);
  double *clean = varied_clean(n), *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
  hetinv_context_t *one = NULL, *two = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  assert_ok(hetinv_context_create(&init, &one));
  init.thread_count = 2;
  assert_ok(hetinv_context_create(&init, &two));
  assert_ok(hetinv_noise_apply(one, &m, clean, a, NULL, n, NULL));
  assert_ok(hetinv_noise_apply(two, &m, clean, b, NULL, n, NULL));
  assert_memory_equal(a, b, n * sizeof *a);
  hetinv_context_destroy(&one);
  hetinv_context_destroy(&two);
  free(clean);
  free(a);
  free(b);
}

static void noise_in_place_equals_noise_into_another_array(void **state) {
  const size_t n = 500;
  hetinv_noise_model_t m;
  hetinv_noise_model_default(&m);
  double *clean = varied_clean(n), *out = malloc(n * sizeof *out);
  assert_ok(hetinv_noise_apply(*state, &m, clean, out, NULL, n, NULL));
  assert_ok(hetinv_noise_apply(*state, &m, clean, clean, NULL, n, NULL));
  assert_memory_equal(clean, out, n * sizeof *out);
  free(clean);
  free(out);
}

/* ------------------------------------------------------------------------ */
/* Errors. */

/* Applies `m` to {1, 2, -0.5, 4} (or `clean`) and expects `code` and `text`,
 * with outputs untouched and exposure_used 0. */
static void expect_failure(hetinv_context_t *ctx, const hetinv_noise_model_t *m,
                           const double *clean, size_t count, hetinv_result_t code,
                           const char *text) {
  double out[4] = {7, 7, 7, 7}, err[4] = {7, 7, 7, 7}, exposure = 7;
  assert_result(code, hetinv_noise_apply(ctx, m, clean, out, err, count, &exposure));
  assert_message_contains(text);
  assert_message_contains("hetinv_noise_apply");
  assert_true(exposure == 0.0);
  for (int i = 0; i < 4; ++i) assert_true(out[i] == 7 && err[i] == 7);
}

static void bad_arguments_fail_with_precise_messages(void **state) {
  hetinv_context_t *ctx = *state;
  const double clean[4] = {1, 2, 3, 4};
  double out[4];
  hetinv_noise_model_t ok, m;
  hetinv_noise_model_default(&ok);
  assert_true(ok.size == sizeof(hetinv_noise_model_t));
  hetinv_noise_model_default(NULL); /* a no-op */

  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_noise_apply(NULL, &ok, clean, out, NULL, 4, NULL));
  assert_message_contains("'ctx' is NULL");
  expect_failure(ctx, NULL, clean, 4, HETINV_ERROR_NULL_ARGUMENT, "'model' is NULL");
  expect_failure(ctx, &ok, NULL, 4, HETINV_ERROR_NULL_ARGUMENT, "'clean' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_noise_apply(ctx, &ok, clean, NULL, NULL, 4, NULL));
  assert_message_contains("'noisy' is NULL");

  m = ok, m.size = sizeof(size_t);
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->size is 8");
  m = ok, m.full_well = 0.0;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->full_well is 0;");
  m = ok, m.full_well = (double)NAN;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->full_well is nan");
  m = ok, m.full_well = 2e15;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->full_well is 2e+15");
  m = ok, m.read_noise = -1.0;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->read_noise is -1;");
  m = ok, m.exposure = -2.0;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->exposure is -2;");
  m = ok, m.exposure = (double)INFINITY;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->exposure is inf");
  m = ok, m.auto_level = 0.0;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->auto_level is 0;");
  m = ok, m.auto_level = 1.5;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT, "model->auto_level is 1.5;");
  expect_failure(ctx, &ok, clean, 0, HETINV_ERROR_INVALID_ARGUMENT, "count is 0");
  m = ok, m.first_index = (UINT64_C(1) << 48) - 3;
  expect_failure(ctx, &m, clean, 4, HETINV_ERROR_INVALID_ARGUMENT,
                 "model->first_index + count is 281474976710653 + 4; it must be <= 2^48");
  m.first_index = (UINT64_C(1) << 48) - 4; /* the last four keys: allowed */
  assert_ok(hetinv_noise_apply(ctx, &m, clean, out, NULL, 4, NULL));

  const double negative[4] = {1, 2, -0.5, 4};
  expect_failure(ctx, &ok, negative, 4, HETINV_ERROR_INVALID_ARGUMENT,
                 "clean[2] is -0.5; it must be finite and >= 0");
  const double not_finite[4] = {1, 2, 3, (double)NAN};
  expect_failure(ctx, &ok, not_finite, 4, HETINV_ERROR_INVALID_ARGUMENT, "clean[3] is nan");
  const double dark[4] = {0, 0, 0, 0};
  expect_failure(ctx, &ok, dark, 4, HETINV_ERROR_INVALID_ARGUMENT,
                 "all 4 clean values are 0; automatic exposure");
  m = ok, m.exposure = 2.0; /* a fixed exposure handles a dark frame */
  assert_ok(hetinv_noise_apply(ctx, &m, dark, out, NULL, 4, NULL));
  const double tiny[4] = {0, 0x1p-1074, 0, 0}; /* the exposure would be infinite */
  expect_failure(ctx, &ok, tiny, 4, HETINV_ERROR_INVALID_ARGUMENT, "automatic exposure inf");
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(poisson_mean_and_variance_equal_lambda),
      cmocka_unit_test(poisson_histogram_matches_pmf),
      cmocka_unit_test(zero_lambda_gives_exactly_zero),
      cmocka_unit_test(read_noise_variance_adds_to_poisson),
      cmocka_unit_test(negative_values_are_kept_so_dark_pixels_stay_unbiased),
      cmocka_unit_test(huge_read_noise_gives_a_finite_std_error),
      cmocka_unit_test(read_noise_leaves_the_photon_counts_unchanged),
      cmocka_unit_test(saturation_clamps_at_the_full_well),
      cmocka_unit_test(automatic_exposure_maps_the_largest_value_to_auto_level),
      cmocka_unit_test(std_errors_are_the_model_deviation_at_the_measurement),
      cmocka_unit_test(same_seed_same_bits_other_seed_other_values),
      cmocka_unit_test(chunks_with_first_index_match_one_call),
      cmocka_unit_test(thread_count_does_not_change_the_values),
      cmocka_unit_test(noise_in_place_equals_noise_into_another_array),
      cmocka_unit_test(bad_arguments_fail_with_precise_messages),
  };
  return cmocka_run_group_tests(tests, ht_context_setup, ht_context_teardown);
}
