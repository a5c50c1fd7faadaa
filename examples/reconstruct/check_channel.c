#include "check_channel.h"

#include <stdio.h>

const float *check_channel(hetinv_context_t *ctx, const char *prog, const char *path, hetinv_image_t **img,
                           const char *name, size_t *n) {
  int32_t w = 0, h = 0, c = -1;
  if (*img == NULL && hetinv_image_read_exr(ctx, path, img) != HETINV_SUCCESS) {
    fprintf(stderr, "%s: %s\n", prog, hetinv_context_last_error_message(ctx));
    return NULL;
  }
  if (hetinv_image_find_channel(*img, name, &c) != HETINV_SUCCESS) {
    fprintf(stderr, "%s: %s has no channel \"%s\"\n", prog, path, name);
    return NULL;
  }
  hetinv_image_get_size(*img, &w, &h, NULL);
  *n = (size_t)w * (size_t)h;
  return hetinv_image_channel_data(*img, c);
}
