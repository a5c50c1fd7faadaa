/* libFuzzer harness of the OpenEXR reader (hetinv_image_read_exr): the input
 * is written to a file and read. A failure must be a file error whose
 * message names the file; an accepted image must survive a write and a
 * second read bit for bit. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "exr_support.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Accepted images up to this many floats are written back and reread. */
enum { MAX_ROUND_TRIP_FLOATS = 1 << 20 };

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  hetinv_context_t *ctx = fx_context();
  char *in = strdup(fx_path("in.exr"));
  CHECK(in != NULL);
  fx_write_file(in, data, size);
  hetinv_image_t *img = (hetinv_image_t *)&img; /* must be reset */
  hetinv_result_t r = hetinv_image_read_exr(ctx, in, &img);
  if (r != HETINV_SUCCESS) {
    CHECK(img == NULL);
    CHECK(r == HETINV_ERROR_CORRUPT_FILE || r == HETINV_ERROR_UNSUPPORTED ||
          r == HETINV_ERROR_SIZE_OVERFLOW || r == HETINV_ERROR_OUT_OF_MEMORY);
    const char *message = hetinv_context_last_error_message(ctx);
    CHECK(message != NULL && strstr(message, in) != NULL); /* names the file */
    free(in);
    return 0;
  }
  int32_t w, h, c;
  CHECK(hetinv_image_get_size(img, &w, &h, &c) == HETINV_SUCCESS);
  CHECK(w > 0 && h > 0 && c > 0);
  for (int32_t k = 0; k < c; ++k) CHECK(hetinv_image_channel_name(img, k) != NULL);
  if ((uint64_t)w * (uint64_t)h * (uint64_t)c <= MAX_ROUND_TRIP_FLOATS) {
    char *out = strdup(fx_path("out.exr"));
    CHECK(out != NULL);
    CHECK(hetinv_image_write_exr(img, out) == HETINV_SUCCESS);
    hetinv_image_t *back = NULL;
    CHECK(hetinv_image_read_exr(ctx, out, &back) == HETINV_SUCCESS);
    fx_check_same(img, back);
    hetinv_image_destroy(&back);
    free(out);
  }
  hetinv_image_destroy(&img);
  free(in);
  return 0;
}
