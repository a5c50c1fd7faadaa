/* Version macros and run-time version agree. */
#include <stdlib.h>

#include "test_support.h"

static void version_number_matches_macros(void **state) {
  (void)state;
  assert_int_equal(hetinv_version_number(), HETINV_VERSION_NUMBER);
  assert_int_equal(HETINV_VERSION_NUMBER,
                   HETINV_VERSION_MAJOR * 10000 + HETINV_VERSION_MINOR * 100 + HETINV_VERSION_PATCH);
}

static void version_string_matches_number(void **state) {
  (void)state;
  assert_string_equal(hetinv_version_string(), HETINV_VERSION_STRING);
  unsigned major, minor, patch;
  assert_int_equal(sscanf(hetinv_version_string(), "%u.%u.%u", &major, &minor, &patch), 3);
  assert_int_equal(major * 10000 + minor * 100 + patch, hetinv_version_number());
}

static void result_names_are_pinned(void **state) {
  (void)state;
  assert_string_equal(hetinv_result_name(HETINV_SUCCESS), "HETINV_SUCCESS");
  assert_string_equal(hetinv_result_name(0), "HETINV_SUCCESS");
  assert_string_equal(hetinv_result_name(1), "HETINV_ERROR_NULL_ARGUMENT");
  assert_string_equal(hetinv_result_name(2), "HETINV_ERROR_INVALID_ARGUMENT");
  assert_string_equal(hetinv_result_name(3), "HETINV_ERROR_OUT_OF_RANGE");
  assert_string_equal(hetinv_result_name(4), "HETINV_ERROR_OUT_OF_MEMORY");
  assert_string_equal(hetinv_result_name(5), "HETINV_ERROR_INVALID_STATE");
  assert_string_equal(hetinv_result_name(6), "HETINV_ERROR_IO");
  assert_string_equal(hetinv_result_name(7), "HETINV_ERROR_CORRUPT_FILE");
  assert_string_equal(hetinv_result_name(8), "HETINV_ERROR_UNSUPPORTED");
  assert_string_equal(hetinv_result_name(9), "HETINV_ERROR_SIZE_OVERFLOW");
  assert_string_equal(hetinv_result_name(10), "HETINV_ERROR_INTERNAL");
}

static void unknown_result_has_a_name(void **state) {
  (void)state;
  assert_string_equal(hetinv_result_name(-1), "HETINV_UNKNOWN_RESULT");
  assert_string_equal(hetinv_result_name(HETINV_RESULT_CODE_COUNT_), "HETINV_UNKNOWN_RESULT");
  assert_string_equal(hetinv_result_name(INT32_MAX), "HETINV_UNKNOWN_RESULT");
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(version_number_matches_macros),
      cmocka_unit_test(version_string_matches_number),
      cmocka_unit_test(result_names_are_pinned),
      cmocka_unit_test(unknown_result_has_a_name),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
