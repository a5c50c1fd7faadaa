/* The ziggurat sampler of free-flight optical depths against Exp(1). */
#include <math.h>
#include <stdlib.h>

#include "core/exponential.h"
#include "test_support.h"

static int compare_doubles(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void layers_tile_the_curve(void **state) {
  (void)state;
  hv_exp_table_t t;
  hv_exp_table_init(&t);
  /* Every layer has the same area; the top one must close at f = 1. */
  double v = t.x[1] * (t.f[2] - t.f[1]);
  for (int i = 1; i < HV_ZIGGURAT_LAYERS; ++i) {
    double area = t.x[i] * (t.f[i + 1] - t.f[i]);
    if (fabs(area - v) > 1e-9 * v) {
      print_error("layer %d has area %.17g, layer 1 %.17g\n", i, area, v);
      fail();
    }
  }
  assert_true(fabs(t.x[0] * exp(-t.x[1]) - v) < 1e-12); /* base strip incl. the tail */
  assert_true(t.x[HV_ZIGGURAT_LAYERS] == 0.0);
}

/* Kolmogorov–Smirnov: the empirical CDF of n draws against 1 - exp(-x). */
static void samples_follow_the_exponential_distribution(void **state) {
  (void)state;
  hv_exp_table_t t;
  hv_exp_table_init(&t);
  const size_t n = 2000000;
  const uint64_t seed = 2024;
  double *x = malloc(n * sizeof *x);
  assert_non_null(x);
  double sum = 0.0, sq = 0.0;
  for (size_t i = 0; i < n; ++i) {
    hv_rng_t rng = hv_rng_init(seed, 0, i, 0);
    x[i] = hv_exp_sample(&t, hv_rng_u64(&rng), &rng);
    sum += x[i];
    sq += x[i] * x[i];
  }
  qsort(x, n, sizeof *x, compare_doubles);
  double d = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double f = 1.0 - exp(-x[i]);
    d = fmax(d, fmax(fabs((double)(i + 1) / n - f), fabs(f - (double)i / n)));
  }
  free(x);
  /* KS critical value at p = 0.001: 1.949 / sqrt(n). */
  double crit = 1.949 / sqrt((double)n);
  double mean = sum / n, var = sq / n - mean * mean;
  if (d > crit || fabs(mean - 1.0) > 4.0 / sqrt((double)n) || fabs(var - 1.0) > 4.0 * sqrt(8.0 / n)) {
    print_error("seed %llu: KS D = %.3g (critical %.3g), mean %.6f, variance %.6f\n",
                (unsigned long long)seed, d, crit, mean, var);
    fail();
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(layers_tile_the_curve),
      cmocka_unit_test(samples_follow_the_exponential_distribution),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
