/* OpenEXR: bit-exact round trips, channel order, attributes, files written
 * by OpenEXR itself, and every way a read or a write can fail. */
#include <math.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openexr.h>
#include <zlib.h>

#include "test_support.h"

static int setup(void **state) {
  ht_tmpdir_create("exr");
  return ht_context_setup(state);
}

static int teardown(void **state) {
  ht_tmpdir_remove();
  return ht_context_teardown(state);
}

/* ---- helpers --------------------------------------------------------------- */

static hetinv_image_t *make(hetinv_context_t *ctx, int32_t w, int32_t h, int32_t c) {
  hetinv_image_t *img = NULL;
  assert_ok(hetinv_image_create(ctx, w, h, c, &img));
  return img;
}

static hetinv_image_t *read_ok(hetinv_context_t *ctx, const char *path) {
  hetinv_image_t *img = NULL;
  assert_ok(hetinv_image_read_exr(ctx, path, &img));
  assert_non_null(img);
  return img;
}

/* Smooth values (they compress) with a few bit patterns ZIP must not alter. */
static void fill(hetinv_image_t *img) {
  int32_t w, h, c;
  assert_ok(hetinv_image_get_size(img, &w, &h, &c));
  for (int32_t k = 0; k < c; ++k) {
    float *p = hetinv_image_channel_data(img, k);
    for (int32_t i = 0; i < w * h; ++i) p[i] = (float)k + 0.001f * (float)i - 0.5f;
  }
  float *p = hetinv_image_channel_data(img, 0);
  p[0] = -0.0f;
  p[1] = 1e-45f; /* subnormal */
  p[2] = INFINITY;
  p[3] = -INFINITY;
  p[4] = NAN;
  p[5] = 3.4028235e38f;
}

static void assert_same_pixels(const hetinv_image_t *a, const hetinv_image_t *b) {
  int32_t wa, ha, ca, wb, hb, cb;
  assert_ok(hetinv_image_get_size(a, &wa, &ha, &ca));
  assert_ok(hetinv_image_get_size(b, &wb, &hb, &cb));
  assert_int_equal(wa, wb);
  assert_int_equal(ha, hb);
  assert_int_equal(ca, cb);
  for (int32_t k = 0; k < ca; ++k) {
    assert_string_equal(hetinv_image_channel_name(a, k), hetinv_image_channel_name(b, k));
    const float *pa = hetinv_image_channel_data((hetinv_image_t *)(uintptr_t)a, k);
    const float *pb = hetinv_image_channel_data((hetinv_image_t *)(uintptr_t)b, k);
    assert_memory_equal(pa, pb, (size_t)wa * (size_t)ha * sizeof(float)); /* bit-exact */
  }
}

static unsigned char *slurp(const char *path, size_t *size) {
  FILE *f = fopen(path, "rb");
  assert_non_null(f);
  assert_int_equal(fseek(f, 0, SEEK_END), 0);
  long n = ftell(f);
  assert_true(n > 0);
  rewind(f);
  unsigned char *bytes = malloc((size_t)n);
  assert_non_null(bytes);
  assert_int_equal(fread(bytes, 1, (size_t)n, f), (size_t)n);
  fclose(f);
  *size = (size_t)n;
  return bytes;
}

/* Writes a small valid file and returns its bytes. */
static unsigned char *valid_file_bytes(hetinv_context_t *ctx, size_t *size) {
  hetinv_image_t *img = make(ctx, 64, 40, 2);
  fill(img);
  assert_ok(hetinv_image_write_exr(img, ht_path("valid.exr")));
  hetinv_image_destroy(&img);
  return slurp(ht_path("valid.exr"), size);
}

static void assert_read_fails(hetinv_context_t *ctx, hetinv_result_t code, const char *path) {
  hetinv_image_t *img = (hetinv_image_t *)&img; /* must be reset to NULL */
  assert_result(code, hetinv_image_read_exr(ctx, path, &img));
  assert_null(img);
}

/* ---- round trips ------------------------------------------------------------- */

static void values_round_trip_bit_exact(void **state) {
  hetinv_image_t *img = make(*state, 37, 23, 3);
  fill(img);
  assert_ok(hetinv_image_set_channel_name(img, 0, "R"));
  assert_ok(hetinv_image_write_exr(img, ht_path("a.exr")));
  assert_int_equal(ht_tmpdir_entry_count(), 1); /* no temporary file left */
  hetinv_image_t *back = read_ok(*state, ht_path("a.exr"));
  assert_same_pixels(img, back);
  assert_int_equal(hetinv_image_attribute_count(back), 0);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
}

static void transient_stack_keeps_its_bins_in_order(void **state) {
  enum { BINS = 40 };
  hetinv_image_t *img = make(*state, 9, 7, BINS);
  for (int32_t k = 0; k < BINS; ++k) {
    char name[16];
    snprintf(name, sizeof name, "tau%03d", (int)k);
    assert_ok(hetinv_image_set_channel_name(img, k, name));
    float *p = hetinv_image_channel_data(img, k);
    for (int i = 0; i < 63; ++i) p[i] = (float)k * 100.0f + (float)i;
  }
  assert_ok(hetinv_image_write_exr(img, ht_path("stack.exr")));
  hetinv_image_t *back = read_ok(*state, ht_path("stack.exr"));
  assert_same_pixels(img, back);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
}

static void unsorted_channel_order_is_restored(void **state) {
  /* OpenEXR stores channels sorted by name; the read restores the image's order. */
  static const char *const names[] = {"z", "tau010", "tau002", "A", "m.x", "B"};
  hetinv_image_t *img = make(*state, 4, 5, 6);
  for (int32_t k = 0; k < 6; ++k) {
    assert_ok(hetinv_image_set_channel_name(img, k, names[k]));
    float *p = hetinv_image_channel_data(img, k);
    for (int i = 0; i < 20; ++i) p[i] = (float)(k * 1000 + i);
  }
  assert_ok(hetinv_image_write_exr(img, ht_path("order.exr")));
  hetinv_image_t *back = read_ok(*state, ht_path("order.exr"));
  assert_same_pixels(img, back);
  assert_int_equal(hetinv_image_attribute_count(back), 0); /* the order is not an attribute */
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
}

static void attributes_round_trip(void **state) {
  hetinv_image_t *img = make(*state, 2, 2, 1);
  char long_name[201];
  memset(long_name, 'n', 200);
  long_name[200] = '\0';
  char *long_value = malloc(65536);
  assert_non_null(long_value);
  memset(long_value, 'v', 65535);
  long_value[65535] = '\0';
  assert_ok(hetinv_image_set_attribute_string(img, "hetinv:units", "1/mm, UTF-8 \xc2\xb5m"));
  assert_ok(hetinv_image_set_attribute_double(img, "bin_width", 0.1));
  assert_ok(hetinv_image_set_attribute_int(img, "seed", INT32_MIN));
  assert_ok(hetinv_image_set_attribute_double(img, "tiny", -4.9e-324));
  assert_ok(hetinv_image_set_attribute_string(img, "empty", ""));
  assert_ok(hetinv_image_set_attribute_string(img, long_name, long_value));
  assert_ok(hetinv_image_set_attribute_int(img, "owner", 7)); /* optional standard names are fine */
  assert_ok(hetinv_image_write_exr(img, ht_path("attr.exr")));
  hetinv_image_t *back = read_ok(*state, ht_path("attr.exr"));
  assert_int_equal(hetinv_image_attribute_count(back), 7);
  for (int32_t i = 0; i < 7; ++i) { /* same order, same types */
    const char *a = NULL, *b = NULL;
    hetinv_attribute_type_t ta, tb;
    assert_ok(hetinv_image_attribute_at(img, i, &a, &ta));
    assert_ok(hetinv_image_attribute_at(back, i, &b, &tb));
    assert_string_equal(a, b);
    assert_int_equal(ta, tb);
  }
  const char *s = NULL;
  double d = 0;
  int32_t n = 0;
  assert_ok(hetinv_image_get_attribute_string(back, "hetinv:units", &s));
  assert_string_equal(s, "1/mm, UTF-8 \xc2\xb5m");
  assert_ok(hetinv_image_get_attribute_double(back, "bin_width", &d));
  assert_true(d == 0.1);
  assert_ok(hetinv_image_get_attribute_double(back, "tiny", &d));
  assert_true(d == -4.9e-324);
  assert_ok(hetinv_image_get_attribute_int(back, "seed", &n));
  assert_int_equal(n, INT32_MIN);
  assert_ok(hetinv_image_get_attribute_int(back, "owner", &n));
  assert_int_equal(n, 7);
  assert_ok(hetinv_image_get_attribute_string(back, "empty", &s));
  assert_string_equal(s, "");
  assert_ok(hetinv_image_get_attribute_string(back, long_name, &s));
  assert_string_equal(s, long_value);
  free(long_value);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
}

static void long_channel_names_round_trip(void **state) {
  hetinv_image_t *img = make(*state, 3, 1, 2);
  char name[256];
  memset(name, 'q', 255);
  name[255] = '\0';
  assert_ok(hetinv_image_set_channel_name(img, 1, name));
  fill(img);
  assert_ok(hetinv_image_write_exr(img, ht_path("long.exr")));
  hetinv_image_t *back = read_ok(*state, ht_path("long.exr"));
  assert_same_pixels(img, back);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
}

static void writing_replaces_an_existing_file(void **state) {
  ht_write_file(ht_path("old.exr"), "old", 3);
  hetinv_image_t *img = make(*state, 2, 3, 1);
  fill(img);
  assert_ok(hetinv_image_write_exr(img, ht_path("old.exr")));
  hetinv_image_t *back = read_ok(*state, ht_path("old.exr"));
  assert_same_pixels(img, back);
  assert_int_equal(ht_tmpdir_entry_count(), 1);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
}

/* ---- chunks that ZIP cannot shrink ------------------------------------------------ */

/* The size OpenEXR 3.1's ZIP gives @p n raw chunk bytes: its predictor (bytes
 * split into even and odd halves, then deltas + 128), then zlib at OpenEXR's
 * default level (-1: zlib's default). */
static size_t zip_size(const unsigned char *raw, size_t n) {
  unsigned char *split = malloc(n), *out = malloc(compressBound((uLong)n));
  assert_true(split != NULL && out != NULL);
  for (size_t i = 0; i < n; ++i) split[i % 2 == 0 ? i / 2 : (n + 1) / 2 + i / 2] = raw[i];
  for (size_t i = n - 1; i > 0; --i) split[i] = (unsigned char)(split[i] - split[i - 1] + 128);
  uLongf size = compressBound((uLong)n);
  assert_int_equal(compress2(out, &size, split, (uLong)n, Z_DEFAULT_COMPRESSION), Z_OK);
  free(split);
  free(out);
  return size;
}

/* Raw chunk bytes that ZIP packs to exactly their own size: noise after a
 * run of zeros, the run's length searched (each zero saves a little). */
static void equal_size_chunk(unsigned char *raw, size_t n) {
  for (size_t zeros = 0; zeros < n; ++zeros) {
    uint32_t s = 2463534242u; /* xorshift32 */
    for (size_t i = 0; i < n; ++i) {
      s ^= s << 13, s ^= s >> 17, s ^= s << 5;
      raw[i] = i < zeros ? 0 : (unsigned char)s;
    }
    if (zip_size(raw, n) == n) return;
  }
  fail_msg("no run of zeros makes %zu bytes of noise ZIP to their own size", n);
}

/* The raw bytes of the file's chunk @p index (checked to be stored raw). */
static void assert_chunk_is_raw(const char *path, int y, const unsigned char *raw, size_t n) {
  exr_context_t exr = NULL;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  assert_int_equal(exr_start_read(&exr, path, &init), EXR_ERR_SUCCESS);
  exr_chunk_info_t chunk;
  assert_int_equal(exr_read_scanline_chunk_info(exr, 0, y, &chunk), EXR_ERR_SUCCESS);
  assert_int_equal(chunk.unpacked_size, n);
  assert_int_equal(chunk.packed_size, n); /* any reader takes this for raw data ... */
  unsigned char *stored = malloc(n);
  assert_non_null(stored);
  assert_int_equal(exr_read_chunk(exr, 0, &chunk, stored), EXR_ERR_SUCCESS);
  assert_memory_equal(stored, raw, n); /* ... so it must be the raw data */
  free(stored);
  exr_finish(&exr);
}

/* OpenEXR 3.1 kept a ZIP chunk that came out exactly as long as the raw data,
 * and every reader takes such a chunk for raw data: the pixels came back
 * scrambled. Here the last chunk (row 16, two channels) is such data. */
static void chunk_zip_cannot_shrink_round_trips(void **state) {
  enum { W = 64, H = 17, C = 2, ROW = W * 4 };
  hetinv_image_t *img = make(*state, W, H, C);
  fill(img); /* rows 0-15: one chunk that compresses */
  unsigned char raw[C * ROW]; /* the last chunk as stored: channel c0's row, then c1's */
  equal_size_chunk(raw, sizeof raw);
  for (int32_t k = 0; k < C; ++k) {
    float *row = hetinv_image_channel_data(img, k) + (size_t)(H - 1) * W;
    for (int32_t x = 0; x < W; ++x) {
      const unsigned char *b = raw + k * ROW + 4 * x;
      uint32_t bits = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 |
                      (uint32_t)b[3] << 24;
      memcpy(&row[x], &bits, sizeof bits);
    }
  }
  assert_ok(hetinv_image_write_exr(img, ht_path("equal.exr")));
  hetinv_image_t *back = read_ok(*state, ht_path("equal.exr"));
  assert_same_pixels(img, back);
  assert_chunk_is_raw(ht_path("equal.exr"), H - 1, raw, sizeof raw);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
}

/* ---- files written by OpenEXR itself -------------------------------------------- */

enum { OW = 5, OH = 3, OX = 10, OY = -20 }; /* data window (10, -20) - (14, -18) */

/* Half bit patterns and the floats they are. */
static const struct {
  uint16_t bits;
  float value;
} halves[OW * OH] = {
    {0x3C00, 1.0f},         {0xC000, -2.0f},     {0x0001, 0x1p-24f}, {0x7BFF, 65504.0f},
    {0x3555, 0.333251953125f}, {0x8000, -0.0f},  {0x7C00, INFINITY}, {0xFC00, -INFINITY},
    {0x0400, 0x1p-14f},     {0x3800, 0.5f},      {0x03FF, 0x3FFp-24f}, {0x5640, 100.0f},
    {0xBC01, -1.0009765625f}, {0x0000, 0.0f},    {0x4248, 3.140625f}};

/* Writes H (half), U (uint) and F (float) channels with OpenEXR's C API,
 * scanline or tiled (2 x 2 tiles, partial at the edges), plus attributes and,
 * if @p order is not NULL, a "hetinv:channelOrder" of 3 names. */
static void write_with_openexr(const char *path, int tiled, const char **order) {
  uint16_t h[OW * OH];
  uint32_t u[OW * OH];
  float f[OW * OH];
  for (int i = 0; i < OW * OH; ++i) {
    h[i] = halves[i].bits;
    u[i] = i == 0 ? 4294967295u : (uint32_t)i * 1000003u;
    f[i] = (float)i * 0.375f - 2.0f;
  }
  exr_context_t exr = NULL;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  int part = 0;
  assert_int_equal(exr_start_write(&exr, path, EXR_WRITE_FILE_DIRECTLY, &init), EXR_ERR_SUCCESS);
  assert_int_equal(
      exr_add_part(exr, NULL, tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part),
      EXR_ERR_SUCCESS);
  exr_attr_box2i_t window = {{{{OX, OY}}}, {{{OX + OW - 1, OY + OH - 1}}}};
  exr_attr_v2f_t center = {{{0.0f, 0.0f}}};
  assert_int_equal(exr_initialize_required_attr(exr, part, &window, &window, 1.0f, &center, 1.0f,
                                                tiled ? EXR_LINEORDER_INCREASING_Y
                                                      : EXR_LINEORDER_DECREASING_Y,
                                                tiled ? EXR_COMPRESSION_PIZ : EXR_COMPRESSION_ZIP),
                   EXR_ERR_SUCCESS);
  if (tiled) {
    assert_int_equal(
        exr_set_tile_descriptor(exr, part, 2, 2, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN),
        EXR_ERR_SUCCESS);
  }
  assert_int_equal(exr_add_channel(exr, part, "H", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LINEAR, 1, 1),
                   EXR_ERR_SUCCESS);
  assert_int_equal(exr_add_channel(exr, part, "U", EXR_PIXEL_UINT, EXR_PERCEPTUALLY_LINEAR, 1, 1),
                   EXR_ERR_SUCCESS);
  assert_int_equal(exr_add_channel(exr, part, "F", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1),
                   EXR_ERR_SUCCESS);
  assert_int_equal(exr_attr_set_float(exr, part, "exposure", 1.5f), EXR_ERR_SUCCESS);
  assert_int_equal(exr_attr_set_int(exr, part, "frame", 42), EXR_ERR_SUCCESS);
  assert_int_equal(exr_attr_set_string(exr, part, "owner", "lab"), EXR_ERR_SUCCESS);
  exr_attr_v2f_t v = {{{1.0f, 2.0f}}};
  assert_int_equal(exr_attr_set_v2f(exr, part, "ignoredVector", &v), EXR_ERR_SUCCESS);
  if (order != NULL) {
    assert_int_equal(exr_attr_set_string_vector(exr, part, "hetinv:channelOrder", 3, order),
                     EXR_ERR_SUCCESS);
  }
  assert_int_equal(exr_write_header(exr), EXR_ERR_SUCCESS);

  exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
  int started = 0;
  int step_x = tiled ? 2 : OW, step_y = tiled ? 2 : 16;
  for (int y0 = 0; y0 < OH; y0 += step_y) {
    for (int x0 = 0; x0 < OW; x0 += step_x) {
      exr_chunk_info_t chunk;
      exr_result_t rv = tiled
                            ? exr_write_tile_chunk_info(exr, part, x0 / 2, y0 / 2, 0, 0, &chunk)
                            : exr_write_scanline_chunk_info(exr, part, OY + y0, &chunk);
      assert_int_equal(rv, EXR_ERR_SUCCESS);
      rv = started ? exr_encoding_update(exr, part, &chunk, &enc)
                   : exr_encoding_initialize(exr, part, &chunk, &enc);
      assert_int_equal(rv, EXR_ERR_SUCCESS);
      for (int c = 0; c < enc.channel_count; ++c) {
        exr_coding_channel_info_t *ch = &enc.channels[c];
        size_t at = (size_t)(y0 * OW + x0);
        int bytes = ch->channel_name[0] == 'H' ? 2 : 4;
        ch->encode_from_ptr = ch->channel_name[0] == 'H'   ? (const uint8_t *)(h + at)
                              : ch->channel_name[0] == 'U' ? (const uint8_t *)(u + at)
                                                           : (const uint8_t *)(f + at);
        ch->user_pixel_stride = bytes;
        ch->user_line_stride = bytes * OW;
        ch->user_bytes_per_element = (int16_t)bytes;
        ch->user_data_type = ch->data_type;
      }
      if (!started) {
        assert_int_equal(exr_encoding_choose_default_routines(exr, part, &enc), EXR_ERR_SUCCESS);
        started = 1;
      }
      assert_int_equal(exr_encoding_run(exr, part, &enc), EXR_ERR_SUCCESS);
    }
  }
  exr_encoding_destroy(exr, &enc);
  assert_int_equal(exr_finish(&exr), EXR_ERR_SUCCESS);
}

/* Reads the file of write_with_openexr; its channels must come in @p order. */
static void check_openexr_file(hetinv_context_t *ctx, const char *path, const char *order) {
  hetinv_image_t *img = read_ok(ctx, path);
  int32_t w, h, c;
  assert_ok(hetinv_image_get_size(img, &w, &h, &c));
  assert_int_equal(w, OW);
  assert_int_equal(h, OH);
  assert_int_equal(c, 3);
  for (int32_t k = 0; k < 3; ++k) {
    const char name[2] = {order[k], '\0'};
    assert_string_equal(hetinv_image_channel_name(img, k), name);
  }
  int32_t kf, kh, ku;
  assert_ok(hetinv_image_find_channel(img, "F", &kf));
  assert_ok(hetinv_image_find_channel(img, "H", &kh));
  assert_ok(hetinv_image_find_channel(img, "U", &ku));
  const float *f = hetinv_image_channel_data(img, kf), *hv = hetinv_image_channel_data(img, kh),
              *u = hetinv_image_channel_data(img, ku);
  for (int i = 0; i < OW * OH; ++i) {
    assert_memory_equal(&hv[i], &halves[i].value, sizeof(float)); /* also -0 and inf */
    float expected_u = i == 0 ? 4294967296.0f : (float)((uint32_t)i * 1000003u);
    assert_true(u[i] == expected_u);
    assert_true(f[i] == (float)i * 0.375f - 2.0f);
  }
  /* float becomes double; the vector and the structural attributes are skipped */
  assert_int_equal(hetinv_image_attribute_count(img), 3);
  double d = 0;
  int32_t n = 0;
  const char *s = NULL;
  assert_ok(hetinv_image_get_attribute_double(img, "exposure", &d));
  assert_true(d == 1.5);
  assert_ok(hetinv_image_get_attribute_int(img, "frame", &n));
  assert_int_equal(n, 42);
  assert_ok(hetinv_image_get_attribute_string(img, "owner", &s));
  assert_string_equal(s, "lab");
  hetinv_image_destroy(&img);
}

static void half_uint_float_scanline_file_is_converted(void **state) {
  write_with_openexr(ht_path("foreign.exr"), 0, NULL);
  check_openexr_file(*state, ht_path("foreign.exr"), "FHU"); /* the file's (sorted) order */
}

static void tiled_file_is_read(void **state) {
  write_with_openexr(ht_path("tiled.exr"), 1, NULL);
  check_openexr_file(*state, ht_path("tiled.exr"), "FHU");
}

static void channel_order_attribute_is_honoured_only_if_valid(void **state) {
  const char *order[] = {"U", "H", "F"};
  write_with_openexr(ht_path("ordered.exr"), 0, order);
  check_openexr_file(*state, ht_path("ordered.exr"), "UHF");
  const char *unknown[] = {"U", "H", "X"}, *twice[] = {"U", "H", "U"};
  write_with_openexr(ht_path("unknown.exr"), 0, unknown);
  check_openexr_file(*state, ht_path("unknown.exr"), "FHU");
  write_with_openexr(ht_path("twice.exr"), 1, twice);
  check_openexr_file(*state, ht_path("twice.exr"), "FHU");
}

/* A header-only file in memory (no pixels are needed to reject it). */
static struct {
  unsigned char bytes[4096];
  size_t size;
} memory_file;

static int64_t write_memory(exr_const_context_t exr, void *user, const void *buffer, uint64_t size,
                            uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
  (void)exr, (void)user, (void)error_cb;
  if (offset + size > sizeof memory_file.bytes) return -1;
  memcpy(memory_file.bytes + offset, buffer, size);
  if (offset + size > memory_file.size) memory_file.size = offset + size;
  return (int64_t)size;
}

static void write_header_only(const char *path, exr_storage_t storage, int sampling) {
  memory_file.size = 0;
  exr_context_t exr = NULL;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.write_fn = write_memory;
  int part = 0;
  assert_int_equal(exr_start_write(&exr, path, EXR_WRITE_FILE_DIRECTLY, &init), EXR_ERR_SUCCESS);
  assert_int_equal(exr_add_part(exr, NULL, storage, &part), EXR_ERR_SUCCESS);
  assert_int_equal(exr_initialize_required_attr_simple(exr, part, 4, 4, EXR_COMPRESSION_NONE),
                   EXR_ERR_SUCCESS);
  assert_int_equal(exr_add_channel(exr, part, "Z", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR,
                                   sampling, sampling),
                   EXR_ERR_SUCCESS);
  assert_int_equal(exr_write_header(exr), EXR_ERR_SUCCESS);
  exr_finish(&exr); /* unfinished: no pixels */
  memset(memory_file.bytes + memory_file.size, 0, 64); /* a zero chunk table */
  ht_write_file(path, memory_file.bytes, memory_file.size + 64);
}

/* Header-only files another tool might write, which the reader must refuse
 * rather than misread. */
enum foreign_header { TWO_PARTS, SHIFTED_DATA_WINDOW, DWAA_COMPRESSED };

static void write_foreign_header(const char *path, enum foreign_header kind) {
  memory_file.size = 0;
  exr_context_t exr = NULL;
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.write_fn = write_memory;
  assert_int_equal(exr_start_write(&exr, path, EXR_WRITE_FILE_DIRECTLY, &init), EXR_ERR_SUCCESS);
  int parts = kind == TWO_PARTS ? 2 : 1;
  const char *names[2] = {"dark", "measurement"};
  for (int i = 0; i < parts; ++i) {
    int part = 0;
    assert_int_equal(exr_add_part(exr, parts > 1 ? names[i] : NULL, EXR_STORAGE_SCANLINE, &part), EXR_ERR_SUCCESS);
    /* the data window one pixel right of and below the display window */
    exr_attr_box2i_t display = {{{{0, 0}}}, {{{3, 3}}}}, data = {{{{1, 1}}}, {{{4, 4}}}};
    exr_attr_v2f_t center = {{{0.0f, 0.0f}}};
    assert_int_equal(exr_initialize_required_attr(exr, part, &display, kind == SHIFTED_DATA_WINDOW ? &data : &display,
                                                  1.0f, &center, 1.0f, EXR_LINEORDER_INCREASING_Y,
                                                  kind == DWAA_COMPRESSED ? EXR_COMPRESSION_DWAA : EXR_COMPRESSION_NONE),
                     EXR_ERR_SUCCESS);
    assert_int_equal(exr_add_channel(exr, part, "L", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1),
                     EXR_ERR_SUCCESS);
  }
  assert_int_equal(exr_write_header(exr), EXR_ERR_SUCCESS);
  exr_finish(&exr); /* unfinished: no pixels */
  memset(memory_file.bytes + memory_file.size, 0, 256); /* zero chunk tables */
  ht_write_file(path, memory_file.bytes, memory_file.size + 256);
}

/* The first part could be a dark frame or a preview with the same channel
 * names: read, it would be taken for the measurement. */
static void multi_part_file_is_refused_naming_its_parts(void **state) {
  write_foreign_header(ht_path("parts.exr"), TWO_PARTS);
  assert_read_fails(*state, HETINV_ERROR_UNSUPPORTED, ht_path("parts.exr"));
  assert_message_contains("has 2 parts (the first two named \"dark\" and \"measurement\")");
}

/* Pixel (0, 0) is the data window's first; a crop or an overscan would move
 * every value to another pixel. */
static void data_window_off_the_display_window_is_refused(void **state) {
  write_foreign_header(ht_path("shifted.exr"), SHIFTED_DATA_WINDOW);
  assert_read_fails(*state, HETINV_ERROR_UNSUPPORTED, ht_path("shifted.exr"));
  assert_message_contains("the data window of");
  assert_message_contains("(1, 1) - (4, 4), is not its display window, (0, 0) - (3, 3)");
}

/* Before OpenEXR 3.1.10 the C core decodes only DWA chunks stored raw: the
 * file is refused whole, not chunk by chunk. */
static void dwa_file_is_refused_whole_by_an_old_openexr(void **state) {
  int major = 0, minor = 0, patch = 0;
  const char *extra = NULL;
  exr_get_library_version(&major, &minor, &patch, &extra);
  if (major > 3 || (major == 3 && (minor > 1 || (minor == 1 && patch >= 10)))) skip();
  write_foreign_header(ht_path("dwaa.exr"), DWAA_COMPRESSED);
  assert_read_fails(*state, HETINV_ERROR_UNSUPPORTED, ht_path("dwaa.exr"));
  assert_message_contains("is DWAA-compressed, which the OpenEXR library in use");
}

static void deep_file_is_unsupported(void **state) {
  write_header_only(ht_path("deep.exr"), EXR_STORAGE_DEEP_SCANLINE, 1);
  assert_read_fails(*state, HETINV_ERROR_UNSUPPORTED, ht_path("deep.exr"));
  assert_message_contains("deep data");
}

static void subsampled_channel_is_unsupported(void **state) {
  write_header_only(ht_path("sub.exr"), EXR_STORAGE_SCANLINE, 2);
  assert_read_fails(*state, HETINV_ERROR_UNSUPPORTED, ht_path("sub.exr"));
  assert_message_contains("channel \"Z\"");
  assert_message_contains("is subsampled (2 x 2)");
}

/* ---- read failures ---------------------------------------------------------- */

static void missing_file_is_an_io_error(void **state) {
  assert_read_fails(*state, HETINV_ERROR_IO, ht_path("nope.exr"));
  assert_message_contains("cannot open '");
  assert_message_contains("nope.exr': No such file or directory");
  assert_read_fails(*state, HETINV_ERROR_IO, ht_path(""));
  assert_message_contains("is not a regular file");
}

/* A FIFO with no writer: refused at once, not waited on. alarm() turns a
 * hang into a failure. */
static void fifo_is_refused_without_waiting(void **state) {
  assert_int_equal(mkfifo(ht_path("fifo.exr"), 0644), 0);
  alarm(20);
  assert_read_fails(*state, HETINV_ERROR_IO, ht_path("fifo.exr"));
  alarm(0);
  assert_message_contains("is not a regular file");
}

static void empty_file_is_corrupt(void **state) {
  ht_write_file(ht_path("empty.exr"), "", 0);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("empty.exr"));
  assert_message_contains("empty.exr' is empty");
}

static void garbage_is_corrupt(void **state) {
  unsigned char junk[1000];
  uint32_t x = 12345;
  for (size_t i = 0; i < sizeof junk; ++i) {
    x = x * 1664525u + 1013904223u;
    junk[i] = (unsigned char)(x >> 24);
  }
  ht_write_file(ht_path("junk.exr"), junk, sizeof junk);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("junk.exr"));
  assert_message_contains("is not a valid OpenEXR file");
  ht_write_file(ht_path("text.exr"), "hello\n", 6);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("text.exr"));
}

static void wrong_magic_is_corrupt(void **state) {
  size_t size;
  unsigned char *bytes = valid_file_bytes(*state, &size);
  bytes[0] ^= 0xff;
  ht_write_file(ht_path("magic.exr"), bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("magic.exr"));
  free(bytes);
}

static void truncated_file_is_corrupt(void **state) {
  size_t size;
  unsigned char *bytes = valid_file_bytes(*state, &size);
  const size_t cuts[] = {1, 4, 8, 20, 100, 300, size / 2, size - 100, size - 8, size - 1};
  for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; ++i) {
    ht_write_file(ht_path("cut.exr"), bytes, cuts[i]);
    hetinv_image_t *img = NULL;
    hetinv_result_t r = hetinv_image_read_exr(*state, ht_path("cut.exr"), &img);
    if (r != HETINV_ERROR_CORRUPT_FILE) {
      print_error("cut at %zu of %zu bytes: %s (%s)\n", cuts[i], size, hetinv_result_name(r),
                  hetinv_context_last_error_message(NULL));
      fail();
    }
    assert_null(img);
  }
  free(bytes);
}

static void corrupt_pixel_data_is_detected(void **state) {
  size_t size;
  unsigned char *bytes = valid_file_bytes(*state, &size);
  for (size_t i = size - 60; i < size - 4; ++i) bytes[i] ^= 0x5a; /* inside the last chunk */
  ht_write_file(ht_path("bad_chunk.exr"), bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("bad_chunk.exr"));
  free(bytes);
}

/* Offset of the 4 int32 of the dataWindow attribute in an EXR header. */
static size_t data_window_offset(const unsigned char *bytes, size_t size) {
  static const char key[] = "dataWindow\0box2i\0"; /* name, type, then int32 size 16 */
  for (size_t i = 0; i + sizeof key + 4 + 16 < size; ++i) {
    if (memcmp(bytes + i, key, sizeof key - 1) == 0) return i + sizeof key - 1 + 4;
  }
  fail_msg("no dataWindow attribute");
  return 0;
}

static void put_i32(unsigned char *p, int32_t v) {
  uint32_t u = (uint32_t)v;
  for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(u >> (8 * i));
}

/* Offset of the channel called @p name (NUL included) in the header's chlist. */
static size_t channel_offset(const unsigned char *bytes, size_t size, const char *name) {
  size_t n = strlen(name) + 1;
  for (size_t i = 0; i + n + 16 < size; ++i) {
    if (memcmp(bytes + i, "chlist", 7) == 0) {
      for (size_t j = i; j + n + 16 < size; ++j) {
        if (memcmp(bytes + j, name, n) == 0) return j;
      }
    }
  }
  fail_msg("no channel \"%s\"", name);
  return 0;
}

/* Every rejection names the file and, where one is at fault, the channel. */
static void malformed_files_name_the_file_and_the_channel(void **state) {
  size_t size;
  unsigned char *bytes = valid_file_bytes(*state, &size);
  const char *path = ht_path("bad_type.exr");
  size_t at = channel_offset(bytes, size, "c1");
  put_i32(bytes + at + 3, 7); /* pixel type 7 */
  ht_write_file(path, bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, path);
  assert_message_contains(path);
  assert_message_contains("Invalid pixel type specified (7) adding channel 'c1'");
  put_i32(bytes + at + 3, 2); /* back to float */

  bytes[at + 1] = 0x7f; /* "c\x7f": not printable */
  path = ht_path("bad_name.exr");
  ht_write_file(path, bytes, size);
  assert_read_fails(*state, HETINV_ERROR_UNSUPPORTED, path);
  assert_message_contains("channel 1 of '");
  assert_message_contains(path);
  bytes[at + 1] = '1';

  put_i32(bytes + at + 3 + 8, 3); /* x sampling 3: 64 pixels are not a multiple */
  path = ht_path("bad_sampling.exr");
  ht_write_file(path, bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, path);
  assert_message_contains(path);
  assert_message_contains("channel 'c1': row width (64) of the data window is not a multiple");
  put_i32(bytes + at + 3 + 8, 2); /* x sampling 2: valid, but not supported */
  path = ht_path("subsampled.exr");
  ht_write_file(path, bytes, size);
  assert_read_fails(*state, HETINV_ERROR_UNSUPPORTED, path);
  assert_message_contains("channel \"c1\" of '");
  assert_message_contains(path);
  assert_message_contains("is subsampled (2 x 1)");
  put_i32(bytes + at + 3 + 8, 1);

  for (size_t i = size - 60; i < size - 4; ++i) bytes[i] ^= 0x5a; /* inside the last chunk */
  path = ht_path("bad_chunk.exr");
  ht_write_file(path, bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, path);
  assert_message_contains(path);
  assert_message_contains("chunk 2 (64 x 8 pixels at 0, 32): "); /* rows 32-39 */
  free(bytes);
}

static void absurd_data_window_fails_before_allocating(void **state) {
  size_t size;
  unsigned char *bytes = valid_file_bytes(*state, &size);
  size_t at = data_window_offset(bytes, size);
  put_i32(bytes + at + 8, 99999); /* 100000 x 100000 pixels in a few kB */
  put_i32(bytes + at + 12, 99999);
  ht_write_file(ht_path("huge.exr"), bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("huge.exr"));

  put_i32(bytes + at + 0, INT32_MIN); /* 2^32 pixels wide */
  put_i32(bytes + at + 8, INT32_MAX);
  ht_write_file(ht_path("wide.exr"), bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("wide.exr"));

  put_i32(bytes + at + 0, 5); /* max < min */
  put_i32(bytes + at + 8, 4);
  ht_write_file(ht_path("inverted.exr"), bytes, size);
  assert_read_fails(*state, HETINV_ERROR_CORRUPT_FILE, ht_path("inverted.exr"));
  free(bytes);
}

static void read_rejects_null_arguments(void **state) {
  hetinv_image_t *img = (hetinv_image_t *)&img;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_read_exr(*state, NULL, &img));
  assert_message_contains("'path' is NULL");
  assert_null(img);
  img = (hetinv_image_t *)&img;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_read_exr(NULL, ht_path("x"), &img));
  assert_null(img);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_read_exr(*state, ht_path("x"), NULL));
}

/* ---- write failures ---------------------------------------------------------- */

static void write_rejects_null_arguments(void **state) {
  hetinv_image_t *img = make(*state, 1, 1, 1);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_write_exr(img, NULL));
  assert_message_contains("'path' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_image_write_exr(NULL, ht_path("x.exr")));
  assert_int_equal(ht_tmpdir_entry_count(), 0);
  hetinv_image_destroy(&img);
}

static void unwritable_destinations_leave_nothing(void **state) {
  hetinv_image_t *img = make(*state, 3, 3, 1);
  assert_result(HETINV_ERROR_IO, hetinv_image_write_exr(img, ht_path("no/such/dir.exr")));
  assert_message_contains("cannot create a temporary file");
  assert_int_equal(ht_tmpdir_entry_count(), 0);
  ht_write_file(ht_path("plain"), "x", 1); /* a file where a directory should be */
  assert_result(HETINV_ERROR_IO, hetinv_image_write_exr(img, ht_path("plain/a.exr")));
  assert_int_equal(ht_tmpdir_entry_count(), 1);
  /* the temporary file is written, then cannot replace a directory */
  assert_int_equal(mkdir(ht_path("dir.exr"), 0755), 0);
  assert_result(HETINV_ERROR_IO, hetinv_image_write_exr(img, ht_path("dir.exr")));
  assert_message_contains("cannot rename the temporary file");
  assert_int_equal(ht_tmpdir_entry_count(), 2); /* plain, dir.exr: no temporary file */
  hetinv_image_destroy(&img);
}

static int alloc_budget = -1; /* allocations left before failing; -1: unlimited */

static void *budget_alloc(void *user, size_t size) {
  (void)user;
  if (alloc_budget == 0) return NULL;
  if (alloc_budget > 0) --alloc_budget;
  return malloc(size);
}
static void budget_free(void *user, void *ptr) {
  (void)user;
  free(ptr);
}

static void failed_write_keeps_the_old_file(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = budget_alloc;
  init.free_fn = budget_free;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  hetinv_image_t *img = make(ctx, 8, 8, 3);
  fill(img);
  ht_write_file(ht_path("keep.exr"), "precious", 8);
  /* Fail each allocation of the write in turn, then let it succeed. */
  hetinv_result_t r = HETINV_ERROR_OUT_OF_MEMORY;
  int failures = 0;
  for (int budget = 0; r != HETINV_SUCCESS; ++budget) {
    alloc_budget = budget;
    r = hetinv_image_write_exr(img, ht_path("keep.exr"));
    alloc_budget = -1;
    if (r == HETINV_SUCCESS) break;
    ++failures;
    assert_int_equal(r, HETINV_ERROR_OUT_OF_MEMORY);
    assert_int_equal(ht_tmpdir_entry_count(), 1);
    size_t size;
    unsigned char *bytes = slurp(ht_path("keep.exr"), &size);
    assert_int_equal(size, 8);
    assert_memory_equal(bytes, "precious", 8);
    free(bytes);
  }
  assert_true(failures >= 2); /* before and after the temporary file exists */
  hetinv_image_t *back = read_ok(ctx, ht_path("keep.exr"));
  assert_same_pixels(img, back);
  hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
}

static void too_many_channels_for_openexr(void **state) {
  hetinv_image_t *img = make(*state, 1, 1, 32768);
  assert_result(HETINV_ERROR_UNSUPPORTED, hetinv_image_write_exr(img, ht_path("many.exr")));
  assert_message_contains("the image has 32768 channels; OpenEXR handles at most 32767");
  assert_int_equal(ht_tmpdir_entry_count(), 0);
  hetinv_image_destroy(&img);
}

#define EXR_TEST(name) cmocka_unit_test_setup_teardown(name, setup, teardown)

int main(void) {
  const struct CMUnitTest tests[] = {
      EXR_TEST(values_round_trip_bit_exact),
      EXR_TEST(transient_stack_keeps_its_bins_in_order),
      EXR_TEST(unsorted_channel_order_is_restored),
      EXR_TEST(attributes_round_trip),
      EXR_TEST(long_channel_names_round_trip),
      EXR_TEST(writing_replaces_an_existing_file),
      EXR_TEST(chunk_zip_cannot_shrink_round_trips),
      EXR_TEST(half_uint_float_scanline_file_is_converted),
      EXR_TEST(tiled_file_is_read),
      EXR_TEST(channel_order_attribute_is_honoured_only_if_valid),
      EXR_TEST(multi_part_file_is_refused_naming_its_parts),
    EXR_TEST(data_window_off_the_display_window_is_refused),
    EXR_TEST(dwa_file_is_refused_whole_by_an_old_openexr),
    EXR_TEST(deep_file_is_unsupported),
      EXR_TEST(subsampled_channel_is_unsupported),
      EXR_TEST(missing_file_is_an_io_error),
      EXR_TEST(fifo_is_refused_without_waiting),
      EXR_TEST(empty_file_is_corrupt),
      EXR_TEST(garbage_is_corrupt),
      EXR_TEST(wrong_magic_is_corrupt),
      EXR_TEST(truncated_file_is_corrupt),
      EXR_TEST(corrupt_pixel_data_is_detected),
      EXR_TEST(absurd_data_window_fails_before_allocating),
      EXR_TEST(malformed_files_name_the_file_and_the_channel),
      EXR_TEST(read_rejects_null_arguments),
      EXR_TEST(write_rejects_null_arguments),
      EXR_TEST(unwritable_destinations_leave_nothing),
      EXR_TEST(failed_write_keeps_the_old_file),
      EXR_TEST(too_many_channels_for_openexr),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
