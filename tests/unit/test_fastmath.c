/* The photon loop's inline elementary functions against libm. */
#include <math.h>
#include <stdlib.h>

#include "core/fastmath.h"
#include "test_support.h"

/* Distance from a to b in units of b's last place. */
static double ulps(double a, double b) {
  double ulp = nextafter(fabs(b), HUGE_VAL) - fabs(b);
  return fabs(a - b) / ulp;
}

static uint64_t lcg(uint64_t *state) {
  *state = *state * 6364136223846793005ULL + 1442695040888963407ULL;
  return *state >> 11;
}

static void log_is_exact_at_one_and_powers_of_two(void **state) {
  (void)state;
  assert_true(hv_log(1.0) == 0.0);
  assert_true(ulps(hv_log(2.0), log(2.0)) <= 1.0);
  assert_true(ulps(hv_log(0.5), log(0.5)) <= 1.0);
  assert_true(ulps(hv_log(0x1p-53), log(0x1p-53)) <= 1.0);
}

static void log_is_within_two_ulps_of_libm(void **state) {
  (void)state;
  uint64_t seed = 12345, s = seed;
  double worst = 0.0, at = 0.0;
  for (int i = 0; i < 3000000; ++i) {
    double u = ((double)lcg(&s) + 0.5) * 0x1p-53;
    /* the free-flight range (0, 1], values near 1, and a wide exponent range */
    double x = i % 3 == 0 ? u : (i % 3 == 1 ? 1.0 - u * 1e-3 : ldexp(0.5 + 0.5 * u, (int)(i % 2000) - 1000));
    double b = log(x);
    if (b == 0.0) continue;
    double d = ulps(hv_log(x), b);
    if (d > worst) worst = d, at = x;
  }
  if (worst > 2.0) {
    print_error("hv_log is %.2f ulp off at x = %.17g (seed %llu)\n", worst, at, (unsigned long long)seed);
    fail();
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(log_is_exact_at_one_and_powers_of_two),
      cmocka_unit_test(log_is_within_two_ulps_of_libm),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
