/* Branch-free selects on doubles (lib/core/bits.h): each gives exactly
 * the value of the select it replaces, signed zeros, infinities and NaN
 * payloads included. */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "test_support.h"

#include "core/bits.h"

static int same_bits(double a, double b) { return hv_bits_of(a) == hv_bits_of(b); }

static const double VALUES[] = {0.0, -0.0, 1.0, -2.5, 1e-310, -1e-310, (double)INFINITY, -(double)INFINITY, (double)NAN, 0x1.fffffffffffffp1023};
enum { COUNT = sizeof VALUES / sizeof VALUES[0] };

static void select_picks_either_value_bit_for_bit(void **state) {
  (void)state;
  for (int i = 0; i < COUNT; ++i) {
    for (int j = 0; j < COUNT; ++j) {
      assert_true(same_bits(hv_select(VALUES[i], VALUES[j], 0), VALUES[i]));
      assert_true(same_bits(hv_select(VALUES[i], VALUES[j], 1), VALUES[j]));
    }
  }
}

static void negate_if_is_ieee_negation(void **state) {
  (void)state;
  for (int i = 0; i < COUNT; ++i) {
    assert_true(same_bits(hv_negate_if(VALUES[i], 0), VALUES[i]));
    assert_true(same_bits(hv_negate_if(VALUES[i], 1), -VALUES[i]));
  }
}

static void keep_if_gives_the_value_or_positive_zero(void **state) {
  (void)state;
  for (int i = 0; i < COUNT; ++i) {
    assert_true(same_bits(hv_keep_if(VALUES[i], 1), VALUES[i]));
    assert_true(same_bits(hv_keep_if(VALUES[i], 0), 0.0));
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(select_picks_either_value_bit_for_bit),
      cmocka_unit_test(negate_if_is_ieee_negation),
      cmocka_unit_test(keep_if_gives_the_value_or_positive_zero),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
