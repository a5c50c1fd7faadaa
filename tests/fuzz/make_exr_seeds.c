/* Writes the seed corpus of fuzz_exr_read into the directory given as the
 * only argument: small files written by hetinv_image_write_exr, and a few
 * written by OpenEXR's C API with what the library does not write itself
 * (tiles; half and uint channels; every other compression).
 * Not run by the tests; rerun it (from the fuzz build) to renew the seeds. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <openexr.h>

#include "hetinv/context.h"
#include "hetinv/io.h"

#define TRY(call) \
  do { \
    if ((call) != 0) { \
      fprintf(stderr, "make_exr_seeds: %s failed\n", #call); \
      exit(1); \
    } \
  } while (0)

static char path[1024];
static const char *dir;

static const char *seed(const char *name) {
  snprintf(path, sizeof path, "%s/%s", dir, name);
  return path;
}

/* An image of the library's own: smooth values and a few special ones. */
static void library_file(hetinv_context_t *ctx, const char *name, int32_t w, int32_t h, int32_t c,
                         int reversed, int attributes) {
  hetinv_image_t *img = NULL;
  TRY(hetinv_image_create(ctx, w, h, c, &img));
  for (int32_t k = 0; k < c; ++k) {
    char channel[16];
    snprintf(channel, sizeof channel, "tau%03d", (int)(reversed ? c - 1 - k : k));
    TRY(hetinv_image_set_channel_name(img, k, channel));
    float *p = hetinv_image_channel_data(img, k);
    for (int32_t i = 0; i < w * h; ++i) p[i] = 0.25f * (float)k + 0.01f * (float)i;
  }
  float *p = hetinv_image_channel_data(img, 0);
  p[0] = -0.0f;
  if (w * h > 1) p[1] = 1e-45f;
  if (attributes) {
    TRY(hetinv_image_set_attribute_string(img, "hetinv:pathlengthType", "bins"));
    TRY(hetinv_image_set_attribute_int(img, "hetinv:binCount", c));
    TRY(hetinv_image_set_attribute_double(img, "hetinv:binWidth", 0.1));
  }
  TRY(hetinv_image_write_exr(img, seed(name)));
  hetinv_image_destroy(&img);
}

/* H (half), U (uint) and F (float) channels, 5 x 3, written by OpenEXR. */
static void openexr_file(const char *name, int tiled, exr_compression_t compression) {
  static const uint16_t halves[15] = {0x3C00, 0xC000, 0x0001, 0x7BFF, 0x3555, 0x8000, 0x7C00, 0xFC00,
                                      0x0400, 0x3800, 0x03FF, 0x5640, 0xBC01, 0x0000, 0x4248};
  uint32_t uints[15];
  float floats[15];
  for (int i = 0; i < 15; ++i) uints[i] = (uint32_t)i * 1000u, floats[i] = (float)i * 0.5f - 3.0f;
  exr_context_t exr = NULL;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  int part = 0;
  TRY(exr_start_write(&exr, seed(name), EXR_WRITE_FILE_DIRECTLY, &init));
  TRY(exr_add_part(exr, NULL, tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part));
  TRY(exr_initialize_required_attr_simple(exr, part, 5, 3, compression));
  if (tiled) TRY(exr_set_tile_descriptor(exr, part, 2, 2, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN));
  TRY(exr_add_channel(exr, part, "H", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LINEAR, 1, 1));
  TRY(exr_add_channel(exr, part, "U", EXR_PIXEL_UINT, EXR_PERCEPTUALLY_LINEAR, 1, 1));
  TRY(exr_add_channel(exr, part, "F", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1));
  TRY(exr_attr_set_float(exr, part, "exposure", 1.5f));
  TRY(exr_attr_set_string(exr, part, "owner", "lab"));
  TRY(exr_write_header(exr));
  exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
  int started = 0, step = 2;
  if (!tiled) TRY(exr_get_scanlines_per_chunk(exr, part, &step));
  for (int y0 = 0; y0 < 3; y0 += step) {
    for (int x0 = 0; x0 < 5; x0 += tiled ? 2 : 5) {
      exr_chunk_info_t chunk;
      TRY(tiled ? exr_write_tile_chunk_info(exr, part, x0 / 2, y0 / 2, 0, 0, &chunk)
                : exr_write_scanline_chunk_info(exr, part, y0, &chunk));
      TRY(started ? exr_encoding_update(exr, part, &chunk, &enc)
                  : exr_encoding_initialize(exr, part, &chunk, &enc));
      for (int c = 0; c < enc.channel_count; ++c) { /* sorted: F, H, U */
        exr_coding_channel_info_t *ch = &enc.channels[c];
        const uint8_t *base = c == 0   ? (const uint8_t *)floats
                              : c == 1 ? (const uint8_t *)halves
                                       : (const uint8_t *)uints;
        int bytes = c == 1 ? 2 : 4;
        ch->encode_from_ptr = base + (size_t)(y0 * 5 + x0) * (size_t)bytes;
        ch->user_pixel_stride = bytes;
        ch->user_line_stride = 5 * bytes;
        ch->user_data_type = ch->data_type;
        ch->user_bytes_per_element = (int16_t)bytes;
      }
      if (!started) TRY(exr_encoding_choose_default_routines(exr, part, &enc));
      started = 1;
      TRY(exr_encoding_run(exr, part, &enc));
    }
  }
  exr_encoding_destroy(exr, &enc);
  TRY(exr_finish(&exr));
}

int main(int argc, char **argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: make_exr_seeds <directory>\n");
    return 2;
  }
  dir = argv[1];
  hetinv_context_t *ctx = NULL;
  TRY(hetinv_context_create(NULL, &ctx));
  library_file(ctx, "lib_1x1.exr", 1, 1, 1, 0, 0);
  library_file(ctx, "lib_6x4_bins.exr", 6, 4, 3, 0, 1);
  library_file(ctx, "lib_3x17_reordered.exr", 3, 17, 2, 1, 1); /* two chunks, channel order */
  hetinv_context_destroy(&ctx);
  /* every compression OpenEXR 3.1 can write (not DWA), so that its
   * decoders get mutated input */
  static const struct {
    const char *name;
    exr_compression_t compression;
  } kinds[] = {{"none", EXR_COMPRESSION_NONE},   {"rle", EXR_COMPRESSION_RLE},
               {"zips", EXR_COMPRESSION_ZIPS},   {"zip", EXR_COMPRESSION_ZIP},
               {"piz", EXR_COMPRESSION_PIZ},     {"pxr24", EXR_COMPRESSION_PXR24},
               {"b44", EXR_COMPRESSION_B44},     {"b44a", EXR_COMPRESSION_B44A}};
  for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; ++i) {
    char name[64];
    snprintf(name, sizeof name, "openexr_scanline_%s.exr", kinds[i].name);
    openexr_file(name, 0, kinds[i].compression);
  }
  openexr_file("openexr_tiled_zip.exr", 1, EXR_COMPRESSION_ZIP);
  openexr_file("openexr_tiled_piz.exr", 1, EXR_COMPRESSION_PIZ);
  return 0;
}
