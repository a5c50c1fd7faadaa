/* Shared helpers of the cmocka tests. Include after <cmocka.h>'s prerequisites. */
#ifndef HETINV_TEST_SUPPORT_H
#define HETINV_TEST_SUPPORT_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "hetinv/hetinv.h"

/* Asserts that a call returns exactly @p code; on mismatch prints both names
 * and the recorded message. */
#define assert_result(code, call) \
  do { \
    hetinv_result_t r_ = (call); \
    if (r_ != (code)) { \
      print_error("%s returned %s, expected %s (message: %s)\n", #call, hetinv_result_name(r_), \
                  hetinv_result_name(code), hetinv_context_last_error_message(NULL)); \
      fail(); \
    } \
  } while (0)

#define assert_ok(call) assert_result(HETINV_SUCCESS, call)

/* Asserts that the calling thread's last error message contains @p text. */
#define assert_message_contains(text) \
  do { \
    const char *m_ = hetinv_context_last_error_message(NULL); \
    if (strstr(m_, (text)) == NULL) { \
      print_error("last error message \"%s\" does not contain \"%s\"\n", m_, (text)); \
      fail(); \
    } \
  } while (0)

/* A fresh, empty directory for this test's files; removed by ht_tmpdir_remove.
 * Returns a static buffer. */
const char *ht_tmpdir_create(const char *test_name);
void ht_tmpdir_remove(void);
/* "<tmpdir>/<name>" in a static rotating buffer (four at a time). */
const char *ht_path(const char *name);
/* Writes @p size bytes to @p path; fails the test on error. */
void ht_write_file(const char *path, const void *data, size_t size);
/* Number of entries in the temporary directory (to prove no stray files). */
int ht_tmpdir_entry_count(void);

/* cmocka group setup/teardown giving every test a context in *state. */
int ht_context_setup(void **state);
int ht_context_teardown(void **state);

/* A non-NULL pointer that is no object of the library: tests that a
 * failing create sets its out-argument to NULL start from it. */
static inline void *ht_sentinel(void) {
  static double storage[4];
  return storage;
}

#endif
