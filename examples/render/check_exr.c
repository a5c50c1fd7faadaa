/* hetinv-render-check: test helper. Reads an OpenEXR file written by
 * hetinv-render with the public API and checks its size, its channels (one
 * per pathlength bin: "L", or "tau0000", "tau0001", ...) and the attributes
 * that describe it; further arguments are files that must exist.
 *
 *   usage: hetinv-render-check FILE.exr CHANNELS WIDTH HEIGHT [FILE...]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <hetinv/hetinv.h>

static int fail(const char *what, const char *detail) {
  fprintf(stderr, "hetinv-render-check: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
  return 1;
}

int main(int argc, char **argv) {
  if (argc < 5) {
    fprintf(stderr, "usage: %s FILE.exr CHANNELS WIDTH HEIGHT [FILE...]\n", argv[0]);
    return 2;
  }
  const int32_t want_c = (int32_t)atoi(argv[2]), want_w = (int32_t)atoi(argv[3]),
                want_h = (int32_t)atoi(argv[4]);
  hetinv_context_t *ctx = NULL;
  hetinv_image_t *img = NULL;
  int status = 1;
  if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS ||
      hetinv_image_read_exr(ctx, argv[1], &img) != HETINV_SUCCESS) {
    status = fail(argv[1], hetinv_context_last_error_message(NULL));
    goto done;
  }
  int32_t w = 0, h = 0, c = 0;
  hetinv_image_get_size(img, &w, &h, &c);
  printf("%s: %d x %d pixels, %d channels\n", argv[1], (int)w, (int)h, (int)c);
  if (w != want_w || h != want_h || c != want_c) {
    char buf[128];
    snprintf(buf, sizeof buf, "expected %d x %d pixels and %d channels", (int)want_w,
             (int)want_h, (int)want_c);
    status = fail(argv[1], buf);
    goto done;
  }
  for (int32_t i = 0; i < c; ++i) {
    char want[32];
    snprintf(want, sizeof want, "tau%04d", (int)i);
    const char *name = hetinv_image_channel_name(img, i);
    if (!(strcmp(name, want) == 0 || (c == 1 && strcmp(name, "L") == 0))) {
      status = fail("unexpected channel name", name);
      goto done;
    }
    const float *px = hetinv_image_channel_data(img, i);
    for (int64_t k = 0; k < (int64_t)w * h; ++k) {
      if (!(px[k] == px[k]) || px[k] < 0.0f) {
        status = fail("a pixel is negative or NaN in channel", name);
        goto done;
      }
    }
  }
  int32_t bins = 0;
  double photons = 0.0;
  const char *type = NULL;
  if (hetinv_image_get_attribute_int(img, "hetinv:binCount", &bins) != HETINV_SUCCESS ||
      bins != c || hetinv_image_get_attribute_double(img, "hetinv:photons", &photons) != HETINV_SUCCESS ||
      hetinv_image_get_attribute_string(img, "hetinv:sensorType", &type) != HETINV_SUCCESS) {
    status = fail(argv[1], "hetinv:binCount, hetinv:photons or hetinv:sensorType missing or wrong");
    goto done;
  }
  for (int32_t i = 0; i < hetinv_image_attribute_count(img); ++i) {
    const char *name = NULL;
    hetinv_attribute_type_t t = 0;
    hetinv_image_attribute_at(img, i, &name, &t);
    if (strncmp(name, "hetinv:", 7) != 0 || strcmp(name, "hetinv:channelOrder") == 0) continue;
    if (t == HETINV_ATTRIBUTE_STRING) {
      const char *s = NULL;
      hetinv_image_get_attribute_string(img, name, &s);
      printf("  %s = \"%.100s%s\"\n", name, s, strlen(s) > 100 ? "..." : "");
    } else if (t == HETINV_ATTRIBUTE_DOUBLE) {
      double d = 0.0;
      hetinv_image_get_attribute_double(img, name, &d);
      printf("  %s = %g\n", name, d);
    } else {
      int32_t v = 0;
      hetinv_image_get_attribute_int(img, name, &v);
      printf("  %s = %d\n", name, (int)v);
    }
  }
  for (int i = 5; i < argc; ++i) {
    FILE *f = fopen(argv[i], "rb");
    if (f == NULL) {
      status = fail("missing file", argv[i]);
      goto done;
    }
    fclose(f);
    printf("%s exists\n", argv[i]);
  }
  status = 0;
done:
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  return status;
}
