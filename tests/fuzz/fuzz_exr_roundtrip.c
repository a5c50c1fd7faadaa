/* libFuzzer harness of the OpenEXR writer and reader together: the input
 * describes a small image (size, channel names and order, pathlength-style
 * header attributes, float bit patterns); it is written with
 * hetinv_image_write_exr, read back, and must come back bit for bit. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "exr_support.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Reads the input front to back; zeros once it is used up. */
typedef struct input {
  const uint8_t *data;
  size_t size, at;
} input_t;

static uint8_t next_byte(input_t *in) { return in->at < in->size ? in->data[in->at++] : 0; }

static uint64_t next_bits(input_t *in, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= (uint64_t)next_byte(in) << (8 * i);
  return v;
}

/* The attributes a pathlength-resolved image carries (examples/render),
 * each with its usual type; the input may also give another type. */
static const char *const attribute_names[] = {
    "hetinv:content",  "hetinv:pathlengthType", "hetinv:binCount",       "hetinv:binWidth",
    "hetinv:binFirstCentre", "hetinv:binSpacing", "hetinv:binCentres",    "hetinv:lengthUnit",
    "hetinv:photons",  "hetinv:seed",           "owner",                 "comments"};
enum { ATTRIBUTE_NAMES = sizeof attribute_names / sizeof attribute_names[0] };

static void add_attribute(hetinv_image_t *img, input_t *in) {
  uint8_t pick = next_byte(in);
  const char *name = attribute_names[(pick & 0x3f) % ATTRIBUTE_NAMES];
  hetinv_result_t r;
  switch (pick >> 6) {
    case 0: { /* string of 0 to 300 bytes, any byte but NUL */
      size_t n = next_byte(in) + (size_t)(next_byte(in) % 46);
      char *s = malloc(n + 1);
      CHECK(s != NULL);
      for (size_t i = 0; i < n; ++i) {
        uint8_t b = next_byte(in);
        s[i] = (char)(b != 0 ? b : 'x');
      }
      s[n] = '\0';
      r = hetinv_image_set_attribute_string(img, name, s);
      free(s);
      break;
    }
    case 1: { /* any bit pattern; non-finite ones are refused */
      uint64_t bits = next_bits(in, 8);
      double d;
      memcpy(&d, &bits, sizeof d);
      r = hetinv_image_set_attribute_double(img, name, d);
      CHECK(r == HETINV_SUCCESS || r == HETINV_ERROR_INVALID_ARGUMENT);
      return;
    }
    default:
      r = hetinv_image_set_attribute_int(img, name, (int32_t)(uint32_t)next_bits(in, 4));
  }
  CHECK(r == HETINV_SUCCESS);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
  hetinv_context_t *ctx = fx_context();
  input_t in = {data, size, 0};
  int32_t w = 1 + next_byte(&in) % 48, h = 1 + next_byte(&in) % 40, c = 1 + next_byte(&in) % 6;
  uint8_t flags = next_byte(&in);
  hetinv_image_t *img = NULL;
  CHECK(hetinv_image_create(ctx, w, h, c, &img) == HETINV_SUCCESS);
  /* channel names: bins "tau000", ... in order or reversed (then the file
   * needs hetinv:channelOrder), or the default c0, c1, ...; maybe one long */
  for (int32_t k = 0; (flags & 3) != 0 && k < c; ++k) {
    char name[16];
    snprintf(name, sizeof name, "tau%03d", (int)((flags & 3) == 2 ? c - 1 - k : k));
    CHECK(hetinv_image_set_channel_name(img, k, name) == HETINV_SUCCESS);
  }
  if (flags & 4) {
    char name[200];
    memset(name, 'L', sizeof name - 1);
    name[sizeof name - 1] = '\0';
    CHECK(hetinv_image_set_channel_name(img, c - 1, name) == HETINV_SUCCESS);
  }
  for (int i = 0, n = (flags >> 3) & 7; i < n; ++i) add_attribute(img, &in);
  /* pixels: the rest of the input as little-endian floats; once it is used
   * up, either zeros (compressible) or noise (about as long zipped as raw) */
  uint32_t noise = 2463534242u ^ (uint32_t)size;
  for (int32_t k = 0; k < c; ++k) {
    float *p = hetinv_image_channel_data(img, k);
    for (int32_t i = 0; i < w * h; ++i) {
      uint32_t bits;
      if (in.at < in.size || !(flags & 0x40)) {
        bits = (uint32_t)next_bits(&in, 4);
      } else {
        noise ^= noise << 13, noise ^= noise >> 17, noise ^= noise << 5;
        bits = noise;
      }
      memcpy(&p[i], &bits, sizeof bits);
    }
  }
  const char *path = fx_path("out.exr");
  CHECK(hetinv_image_write_exr(img, path) == HETINV_SUCCESS);
  hetinv_image_t *back = NULL;
  CHECK(hetinv_image_read_exr(ctx, path, &back) == HETINV_SUCCESS);
  fx_check_same(img, back);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
  return 0;
}
