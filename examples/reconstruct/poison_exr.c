/* hetinv-exr-poison: test helper. Copies an OpenEXR file with one value
 * replaced (by "nan", "inf" or a number), to test that readers of
 * measured files refuse it with a message naming the channel and pixel;
 * or with every value of every channel multiplied by FACTOR (data of an
 * instrument with another gain, to test the calibration gain); or with one
 * more channel NAME of zeros (readers must ignore channels they do not use).
 *
 *   usage: hetinv-exr-poison IN.exr OUT.exr CHANNEL X Y VALUE
 *          hetinv-exr-poison IN.exr OUT.exr --scale FACTOR
 *          hetinv-exr-poison IN.exr OUT.exr --add-channel NAME
 */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <hetinv/hetinv.h>

/* IN's channels and attributes and one more channel `name` of zeros, written to OUT. */
static int add_channel(const char *in, const char *out, const char *name) {
  hetinv_context_t *ctx = NULL;
  hetinv_image_t *img = NULL, *wider = NULL;
  int32_t w = 0, h = 0, channels = 0;
  hetinv_result_t r = hetinv_context_create(NULL, &ctx);
  if (r == HETINV_SUCCESS) r = hetinv_image_read_exr(ctx, in, &img);
  if (r == HETINV_SUCCESS) r = hetinv_image_get_size(img, &w, &h, &channels);
  if (r == HETINV_SUCCESS) r = hetinv_image_create(ctx, w, h, channels + 1, &wider);
  for (int32_t k = 0; r == HETINV_SUCCESS && k < channels; ++k) {
    memcpy(hetinv_image_channel_data(wider, k), hetinv_image_channel_data(img, k), (size_t)w * (size_t)h * sizeof(float));
    r = hetinv_image_set_channel_name(wider, k, hetinv_image_channel_name(img, k));
  }
  if (r == HETINV_SUCCESS) r = hetinv_image_set_channel_name(wider, channels, name);
  for (int32_t a = 0; r == HETINV_SUCCESS && a < hetinv_image_attribute_count(img); ++a) {
    const char *key = NULL, *text = NULL;
    hetinv_attribute_type_t type = HETINV_ATTRIBUTE_STRING;
    double d = 0.0;
    int32_t i = 0;
    r = hetinv_image_attribute_at(img, a, &key, &type);
    if (r == HETINV_SUCCESS && type == HETINV_ATTRIBUTE_STRING) {
      r = hetinv_image_get_attribute_string(img, key, &text);
      if (r == HETINV_SUCCESS) r = hetinv_image_set_attribute_string(wider, key, text);
    } else if (r == HETINV_SUCCESS && type == HETINV_ATTRIBUTE_DOUBLE) {
      r = hetinv_image_get_attribute_double(img, key, &d);
      if (r == HETINV_SUCCESS) r = hetinv_image_set_attribute_double(wider, key, d);
    } else if (r == HETINV_SUCCESS) {
      r = hetinv_image_get_attribute_int(img, key, &i);
      if (r == HETINV_SUCCESS) r = hetinv_image_set_attribute_int(wider, key, i);
    }
  }
  if (r == HETINV_SUCCESS) r = hetinv_image_write_exr(wider, out);
  if (r != HETINV_SUCCESS) fprintf(stderr, "hetinv-exr-poison: %s: %s\n", in, hetinv_context_last_error_message(ctx));
  hetinv_image_destroy(&wider);
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  return r == HETINV_SUCCESS ? 0 : 1;
}

int main(int argc, char **argv) {
  const bool scale = argc == 5 && strcmp(argv[3], "--scale") == 0;
  if (argc == 5 && strcmp(argv[3], "--add-channel") == 0) return add_channel(argv[1], argv[2], argv[4]);
  if (argc != 7 && !scale) {
    fprintf(stderr, "usage: %s IN.exr OUT.exr CHANNEL X Y VALUE\n"
                    "       %s IN.exr OUT.exr --scale FACTOR\n"
                    "       %s IN.exr OUT.exr --add-channel NAME\n", argv[0], argv[0], argv[0]);
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  hetinv_image_t *img = NULL;
  int status = 1;
  int32_t c = -1, w = 0, h = 0;
  if (scale) {
    const double factor = atof(argv[4]);
    int32_t channels = 0;
    if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS || hetinv_image_read_exr(ctx, argv[1], &img) != HETINV_SUCCESS) {
      fprintf(stderr, "hetinv-exr-poison: %s: %s\n", argv[1], hetinv_context_last_error_message(ctx));
      goto done;
    }
    hetinv_image_get_size(img, &w, &h, &channels);
    for (int32_t k = 0; k < channels; ++k) {
      float *px = hetinv_image_channel_data(img, k);
      for (size_t i = 0; i < (size_t)w * (size_t)h; ++i) px[i] = (float)((double)px[i] * factor);
    }
    if (hetinv_image_write_exr(img, argv[2]) != HETINV_SUCCESS) {
      fprintf(stderr, "hetinv-exr-poison: %s: %s\n", argv[2], hetinv_context_last_error_message(ctx));
      goto done;
    }
    status = 0;
    goto done;
  }
  const int x = atoi(argv[4]), y = atoi(argv[5]);
  const float value = strcmp(argv[6], "nan") == 0 ? NAN : strcmp(argv[6], "inf") == 0 ? INFINITY
                                                                                    : (float)atof(argv[6]);
  if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS || hetinv_image_read_exr(ctx, argv[1], &img) != HETINV_SUCCESS ||
      hetinv_image_find_channel(img, argv[3], &c) != HETINV_SUCCESS) {
    fprintf(stderr, "hetinv-exr-poison: %s: %s\n", argv[1], hetinv_context_last_error_message(ctx));
    goto done;
  }
  hetinv_image_get_size(img, &w, &h, NULL);
  if (x < 0 || x >= w || y < 0 || y >= h) {
    fprintf(stderr, "hetinv-exr-poison: pixel (%d, %d) is outside %d x %d\n", x, y, (int)w, (int)h);
    goto done;
  }
  hetinv_image_channel_data(img, c)[(size_t)y * (size_t)w + (size_t)x] = value;
  if (hetinv_image_write_exr(img, argv[2]) != HETINV_SUCCESS) {
    fprintf(stderr, "hetinv-exr-poison: %s: %s\n", argv[2], hetinv_context_last_error_message(ctx));
    goto done;
  }
  status = 0;
done:
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  return status;
}
