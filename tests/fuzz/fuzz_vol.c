/* libFuzzer harness of the .vol parser (hv_vol_parse): every input is parsed
 * header-only, then in full; the parser must never crash, and what it
 * accepts must be self-consistent. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "io/vol_format.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Bounds the harness's allocation. An accepted header already implies
 * size == 48 + 4·count, so this only matters with -max_len beyond 64 MiB. */
enum { MAX_FLOATS = 1 << 24 };

#define CHECK(cond) \
  do { \
    if (!(cond)) __builtin_trap(); \
  } while (0)

static int is_zero(const hetinv_vol_header_t *h) {
  static const hetinv_vol_header_t zero;
  return memcmp(h, &zero, sizeof zero) == 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  static const char source[] = "the fuzz input";
  hetinv_vol_header_t h, full;
  if (hv_vol_parse(NULL, source, data, size, &h, NULL, 0) != HETINV_SUCCESS) {
    CHECK(is_zero(&h));
    return 0;
  }
  CHECK(h.channels == 1 || h.channels == 3);
  CHECK(h.dims[0] > 0 && h.dims[1] > 0 && h.dims[2] > 0);
  size_t count = (size_t)h.dims[0] * (size_t)h.dims[1] * (size_t)h.dims[2] * (size_t)h.channels;
  CHECK(size == HV_VOL_HEADER_SIZE + 4 * count);
  size_t capacity = count < MAX_FLOATS ? count : MAX_FLOATS;
  float *values = malloc(capacity * sizeof *values);
  if (values == NULL) return 0;
  hetinv_result_t r = hv_vol_parse(NULL, source, data, size, &full, values, capacity);
  if (r == HETINV_SUCCESS) {
    CHECK(memcmp(&h, &full, sizeof h) == 0);
    for (size_t i = 0; i < count; ++i) CHECK(isfinite(values[i]));
  } else {
    CHECK(r == HETINV_ERROR_CORRUPT_FILE ||
          (r == HETINV_ERROR_INVALID_ARGUMENT && capacity < count));
    CHECK(is_zero(&full));
  }
  /* One float short is always refused. */
  r = hv_vol_parse(NULL, source, data, size, &full, values, count - 1);
  CHECK(r == HETINV_ERROR_INVALID_ARGUMENT && is_zero(&full));
  free(values);
  return 0;
}
