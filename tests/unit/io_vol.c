/* Mitsuba .vol files: layout, round trips, every reader and writer error,
 * and the medium's .vol reader and writer. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "test_support.h"

enum { HEADER = 48, MAX_VALUES = 64 };

static int setup(void **state) {
  ht_tmpdir_create("vol");
  return ht_context_setup(state);
}

static int teardown(void **state) {
  ht_tmpdir_remove();
  return ht_context_teardown(state);
}

/* ---- hand-built files ---------------------------------------------------- */

static void le32(unsigned char *p, uint32_t u) {
  for (int i = 0; i < 4; ++i) p[i] = (unsigned char)(u >> (8 * i) & 0xffu);
}

static void lef(unsigned char *p, float f) {
  uint32_t u;
  memcpy(&u, &f, sizeof u);
  le32(p, u);
}

/* "VOL", version 3, float32 encoding, the given grid, box [0, 1]^3. */
static void make_header(unsigned char h[HEADER], int32_t nx, int32_t ny, int32_t nz, int32_t ch) {
  memcpy(h, "VOL\3", 4);
  le32(h + 4, 1);
  le32(h + 8, (uint32_t)nx);
  le32(h + 12, (uint32_t)ny);
  le32(h + 16, (uint32_t)nz);
  le32(h + 20, (uint32_t)ch);
  for (int i = 0; i < 3; ++i) {
    lef(h + 24 + 4 * i, 0.0f);
    lef(h + 36 + 4 * i, 1.0f);
  }
}

/* Writes tmpdir/name: the first @p header_bytes of @p h, then @p n values. */
static const char *write_raw(const char *name, const unsigned char *h, size_t header_bytes,
                             const float *values, size_t n) {
  unsigned char buf[HEADER + 4 * MAX_VALUES];
  assert_true(header_bytes <= HEADER && n <= MAX_VALUES);
  memcpy(buf, h, header_bytes);
  for (size_t k = 0; k < n; ++k) lef(buf + header_bytes + 4 * k, values[k]);
  const char *path = ht_path(name);
  ht_write_file(path, buf, header_bytes + 4 * n);
  return path;
}

/* A file with a whole header for the grid and @p n values 0, 1, 2, .... */
static const char *write_grid(const char *name, int32_t nx, int32_t ny, int32_t nz, int32_t ch,
                              size_t n) {
  unsigned char h[HEADER];
  float v[MAX_VALUES];
  make_header(h, nx, ny, nz, ch);
  for (size_t k = 0; k < MAX_VALUES; ++k) v[k] = (float)k;
  return write_raw(name, h, HEADER, v, n);
}

static size_t read_all(const char *path, unsigned char *buf, size_t capacity) {
  FILE *f = fopen(path, "rb");
  assert_non_null(f);
  size_t n = fread(buf, 1, capacity, f);
  fclose(f);
  return n;
}

/* Both readers fail with @p code and @p text, and zero the header. With
 * values_only, the header alone is fine and only hetinv_vol_read fails. */
static void expect_read_failure(hetinv_context_t *ctx, const char *path, hetinv_result_t code,
                                const char *text, int values_only) {
  hetinv_vol_header_t h;
  float data[MAX_VALUES];
  memset(&h, 0x5a, sizeof h);
  assert_result(code, hetinv_vol_read(ctx, path, &h, data, MAX_VALUES));
  assert_message_contains(text);
  assert_int_equal(h.dims[0], 0);
  assert_int_equal(h.channels, 0);
  assert_true(h.box_max[2] == 0.0);
  memset(&h, 0x5a, sizeof h);
  if (values_only) {
    assert_ok(hetinv_vol_read_header(ctx, path, &h));
    return;
  }
  assert_result(code, hetinv_vol_read_header(ctx, path, &h));
  assert_message_contains(text);
  assert_int_equal(h.dims[0], 0);
}

static hetinv_vol_header_t grid_header(int32_t nx, int32_t ny, int32_t nz, int32_t ch) {
  hetinv_vol_header_t h = {{nx, ny, nz}, ch, {-1.0, -2.0, -3.0}, {1.0, 2.0, 3.0}};
  return h;
}

/* ---- layout and round trips --------------------------------------------- */

static void round_trip(hetinv_context_t *ctx, int32_t channels) {
  hetinv_vol_header_t h = {{3, 2, 2}, channels, {-0.5, 0.0, 10.0}, {0.5, 2.25, 12.0}};
  size_t n = 12 * (size_t)channels;
  float values[36], back[36];
  for (size_t i = 0; i < n; ++i) values[i] = (float)i * 0.37f - 3.0f;
  const char *path = ht_path("round.vol");
  assert_ok(hetinv_vol_write(ctx, path, &h, values, n));
  hetinv_vol_header_t r;
  assert_ok(hetinv_vol_read(ctx, path, &r, back, 36));
  assert_memory_equal(r.dims, h.dims, sizeof h.dims);
  assert_int_equal(r.channels, channels);
  for (int i = 0; i < 3; ++i) {
    assert_true(r.box_min[i] == h.box_min[i]);
    assert_true(r.box_max[i] == h.box_max[i]);
  }
  assert_memory_equal(back, values, n * sizeof(float));
  assert_int_equal(ht_tmpdir_entry_count(), 1); /* no temporary file left */
}

static void one_channel_round_trip_keeps_values_and_box(void **state) { round_trip(*state, 1); }

static void three_channel_round_trip_keeps_values_and_box(void **state) {
  round_trip(*state, 3);
}

static void written_file_has_the_mitsuba_byte_layout(void **state) {
  hetinv_vol_header_t h = grid_header(2, 1, 1, 1);
  const float values[2] = {0.5f, -2.0f};
  const char *path = ht_path("layout.vol");
  assert_ok(hetinv_vol_write(*state, path, &h, values, 2));
  static const unsigned char expected[HEADER + 8] = {
      'V', 'O', 'L', 3, 1, 0, 0, 0,                                /* magic, version, float32 */
      2, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0,              /* xres yres zres channels */
      0, 0, 0x80, 0xbf, 0, 0, 0, 0xc0, 0, 0, 0x40, 0xc0,           /* -1 -2 -3 */
      0, 0, 0x80, 0x3f, 0, 0, 0, 0x40, 0, 0, 0x40, 0x40,           /* 1 2 3 */
      0, 0, 0, 0x3f, 0, 0, 0, 0xc0};                               /* 0.5 -2 */
  unsigned char bytes[128];
  assert_int_equal(read_all(path, bytes, sizeof bytes), sizeof expected);
  assert_memory_equal(bytes, expected, sizeof expected);
}

static void hand_built_file_is_read_in_file_order(void **state) {
  const char *path = write_grid("order.vol", 2, 2, 2, 3, 24);
  hetinv_vol_header_t h;
  float data[MAX_VALUES];
  assert_ok(hetinv_vol_read(*state, path, &h, data, MAX_VALUES));
  assert_int_equal(h.dims[0], 2);
  assert_int_equal(h.dims[2], 2);
  assert_int_equal(h.channels, 3);
  assert_true(h.box_min[0] == 0.0 && h.box_max[1] == 1.0);
  for (int i = 0; i < 24; ++i) assert_true(data[i] == (float)i);
}

static void header_read_reports_dims_without_values(void **state) {
  const char *path = write_grid("head.vol", 4, 3, 2, 1, 24);
  hetinv_vol_header_t h;
  assert_ok(hetinv_vol_read_header(*state, path, &h));
  assert_int_equal(h.dims[0], 4);
  assert_int_equal(h.dims[1], 3);
  assert_int_equal(h.dims[2], 2);
  assert_int_equal(h.channels, 1);
}

static void degenerate_box_is_accepted_by_the_reader(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  lef(h + 36 + 8, 0.0f); /* zmax = zmin */
  const float v = 2.0f;
  const char *path = write_raw("flat.vol", h, HEADER, &v, 1);
  hetinv_vol_header_t r;
  assert_ok(hetinv_vol_read_header(*state, path, &r));
  assert_true(r.box_min[2] == 0.0 && r.box_max[2] == 0.0);
}

/* ---- reader errors ------------------------------------------------------ */

static void missing_file_is_an_io_error(void **state) {
  expect_read_failure(*state, ht_path("nothing.vol"), HETINV_ERROR_IO, "nothing.vol", 0);
  assert_message_contains("cannot open");
}

static void directory_is_an_io_error(void **state) {
  const char *path = ht_path("dir.vol");
  assert_int_equal(mkdir(path, 0755), 0);
  expect_read_failure(*state, path, HETINV_ERROR_IO, "is not a regular file", 0);
}

/* A FIFO with no writer: refused at once, not waited on (its open used to
 * block until a writer came). alarm() turns a hang into a failure. */
static void fifo_is_refused_without_waiting(void **state) {
  const char *path = ht_path("fifo.vol");
  assert_int_equal(mkfifo(path, 0644), 0);
  alarm(20);
  expect_read_failure(*state, path, HETINV_ERROR_IO, "is not a regular file", 0);
  alarm(0);
}

static void empty_file_is_corrupt(void **state) {
  const char *path = ht_path("empty.vol");
  ht_write_file(path, "", 0);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE, "empty.vol' is empty", 0);
}

static void truncated_header_is_corrupt(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  const char *path = write_raw("short.vol", h, 30, NULL, 0);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE,
                      "truncated: the header needs 48 bytes, there are 30", 0);
}

static void truncated_data_is_corrupt(void **state) {
  const char *path = write_grid("cut.vol", 2, 2, 2, 1, 7);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE,
                      "truncated: the header says 8 values (32 bytes), the file holds 28 bytes",
                      0);
}

static void wrong_magic_is_corrupt(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  memcpy(h, "BMP", 3);
  const float v = 1.0f;
  const char *path = write_raw("magic.vol", h, HEADER, &v, 1);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE,
                      "magic.vol' is not a .vol file: it starts with \"\\x42\\x4d\\x50\"", 0);
}

static void version_2_is_unsupported(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  h[3] = 2;
  const float v = 1.0f;
  const char *path = write_raw("v2.vol", h, HEADER, &v, 1);
  expect_read_failure(*state, path, HETINV_ERROR_UNSUPPORTED, ".vol version 2", 0);
}

static void float16_encoding_is_unsupported(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  le32(h + 4, 2);
  const float v = 1.0f;
  const char *path = write_raw("half.vol", h, HEADER, &v, 1);
  expect_read_failure(*state, path, HETINV_ERROR_UNSUPPORTED, "encoding is 2 (float16)", 0);
}

/* A big-endian writer's float32 file: its encoding 1 reads as 2^24. */
static void big_endian_file_is_named_as_such(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  le32(h + 4, UINT32_C(1) << 24);
  const float v = 1.0f;
  const char *path = write_raw("be.vol", h, HEADER, &v, 1);
  expect_read_failure(*state, path, HETINV_ERROR_UNSUPPORTED,
                      "encoding is 16777216 (unknown); only 1 (float32) is supported: the file looks big-endian", 0);
}

static void uint8_and_direction_encodings_are_named(void **state) {
  static const char *const expected[2] = {"encoding is 3 (uint8)",
                                          "encoding is 4 (quantized directions)"};
  for (uint32_t e = 3; e <= 4; ++e) {
    unsigned char h[HEADER];
    make_header(h, 1, 1, 1, 1);
    le32(h + 4, e);
    const float v = 1.0f;
    const char *path = write_raw("enc.vol", h, HEADER, &v, 1);
    expect_read_failure(*state, path, HETINV_ERROR_UNSUPPORTED, expected[e - 3], 0);
  }
}

static void two_channels_are_unsupported(void **state) {
  const char *path = write_grid("two.vol", 1, 1, 1, 2, 2);
  expect_read_failure(*state, path, HETINV_ERROR_UNSUPPORTED, "channels is 2", 0);
}

static void zero_dimension_is_corrupt(void **state) {
  const char *path = write_grid("zero.vol", 2, 0, 2, 1, 0);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE, "yres is 0; it must be > 0", 0);
}

static void negative_dimension_is_corrupt(void **state) {
  const char *path = write_grid("neg.vol", 2, 2, -4, 1, 0);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE, "zres is -4; it must be > 0", 0);
}

static void overflowing_dimensions_are_a_size_overflow(void **state) {
  const char *path = write_grid("huge.vol", INT32_MAX, INT32_MAX, INT32_MAX, 3, 4);
  expect_read_failure(*state, path, HETINV_ERROR_SIZE_OVERFLOW,
                      "2147483647 x 2147483647 x 2147483647 voxels, channels 3, overflow size_t",
                      0);
}

static void absurd_dimensions_with_a_tiny_file_fail_before_reading(void **state) {
  /* 2^50 values would be 4 PiB: the size check must come before any allocation or read. */
  const char *path = write_grid("absurd.vol", 1 << 20, 1 << 20, 1 << 10, 1, 1);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE,
                      "truncated: the header says 1125899906842624 values", 0);
}

static void non_finite_box_is_corrupt(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  lef(h + 24 + 4, NAN); /* ymin */
  const float v = 1.0f;
  const char *path = write_raw("nanbox.vol", h, HEADER, &v, 1);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE, "the box along y is [nan, 1]",
                      0);
}

static void inverted_box_is_corrupt(void **state) {
  unsigned char h[HEADER];
  make_header(h, 1, 1, 1, 1);
  lef(h + 24, 2.0f); /* xmin > xmax */
  const float v = 1.0f;
  const char *path = write_raw("inverted.vol", h, HEADER, &v, 1);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE, "the box along x is [2, 1]", 0);
}

static void nan_value_is_corrupt_and_names_voxel_and_channel(void **state) {
  unsigned char h[HEADER];
  float v[24] = {0};
  make_header(h, 2, 2, 2, 3);
  v[((1 * 2 + 0) * 2 + 1) * 3 + 2] = NAN; /* voxel (1, 0, 1), channel 2 */
  const char *path = write_raw("nan.vol", h, HEADER, v, 24);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE,
                      "the value of voxel (1, 0, 1), channel 2 is nan", 1);
}

static void infinite_value_is_corrupt(void **state) {
  unsigned char h[HEADER];
  float v[6] = {0};
  make_header(h, 3, 2, 1, 1);
  v[5] = -INFINITY; /* voxel (2, 1, 0) */
  const char *path = write_raw("inf.vol", h, HEADER, v, 6);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE,
                      "voxel (2, 1, 0), channel 0 is -inf", 1);
}

static void trailing_bytes_are_corrupt(void **state) {
  const char *path = write_grid("long.vol", 2, 1, 1, 1, 3);
  expect_read_failure(*state, path, HETINV_ERROR_CORRUPT_FILE,
                      "4 trailing bytes after the 2 values", 0);
}

static void too_small_capacity_is_an_invalid_argument(void **state) {
  const char *path = write_grid("cap.vol", 2, 2, 1, 3, 12);
  hetinv_vol_header_t h;
  float data[12];
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_vol_read(*state, path, &h, data, 11));
  assert_message_contains("capacity is 11 floats");
  assert_message_contains("holds 12 values");
  assert_int_equal(h.dims[0], 0);
}

static void null_arguments_are_rejected(void **state) {
  hetinv_context_t *ctx = *state;
  const char *path = write_grid("ok.vol", 1, 1, 1, 1, 1);
  hetinv_vol_header_t h = grid_header(1, 1, 1, 1);
  float v = 0.0f;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_read_header(NULL, path, &h));
  assert_message_contains("'ctx' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_read_header(ctx, NULL, &h));
  assert_message_contains("'path' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_read_header(ctx, path, NULL));
  assert_message_contains("'header' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_read(ctx, path, &h, NULL, 1));
  assert_message_contains("'data' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_read(ctx, path, NULL, &v, 1));
  h = grid_header(1, 1, 1, 1);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_write(NULL, path, &h, &v, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_write(ctx, NULL, &h, &v, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_write(ctx, path, NULL, &v, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_vol_write(ctx, path, &h, NULL, 1));
  assert_message_contains("hetinv_vol_write: 'data' is NULL");
}

/* ---- writer errors ------------------------------------------------------ */

static void bad_header_is_rejected_and_leaves_no_file(void **state) {
  struct {
    hetinv_vol_header_t h;
    const char *text;
  } cases[] = {
      {grid_header(0, 1, 1, 1), "header->dims[0] (xres) is 0"},
      {grid_header(1, 1, -2, 1), "header->dims[2] (zres) is -2"},
      {grid_header(1, 1, 1, 2), "header->channels is 2"},
      {{{1, 1, 1}, 1, {0, 0, 0}, {1, 0, 1}}, "the box along y is [0, 0]"},
      {{{1, 1, 1}, 1, {0, 0, (double)INFINITY}, {1, 1, 1}}, "the box along z is [inf, 1]"},
      {{{1, 1, 1}, 1, {0, 0, 0}, {1e300, 1, 1}}, "the box along x is [0, 1e+300]"},
      /* Distinct in double, equal once stored as float32. */
      {{{1, 1, 1}, 1, {0, 0, 1}, {1, 1, 1 + 1e-12}}, "the box along z is [1, 1]; both ends must be finite float32 "
                                                   "values and box_min < box_max in float32"},
  };
  const float v[1] = {1.0f};
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
    assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                  hetinv_vol_write(*state, ht_path("bad.vol"), &cases[i].h, v, 1));
    assert_message_contains(cases[i].text);
    assert_int_equal(ht_tmpdir_entry_count(), 0);
  }
}

static void overflowing_header_is_a_size_overflow(void **state) {
  hetinv_vol_header_t h = grid_header(INT32_MAX, INT32_MAX, INT32_MAX, 3);
  const float v[1] = {1.0f};
  assert_result(HETINV_ERROR_SIZE_OVERFLOW, hetinv_vol_write(*state, ht_path("big.vol"), &h, v, 1));
  assert_message_contains("overflow size_t");
  assert_int_equal(ht_tmpdir_entry_count(), 0);
}

static void non_finite_value_is_rejected_naming_it_and_leaves_no_file(void **state) {
  hetinv_vol_header_t h = grid_header(2, 2, 1, 3);
  float v[12] = {0};
  v[10] = NAN; /* voxel (1, 1, 0), channel 1 */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_vol_write(*state, ht_path("nan.vol"), &h, v, 12));
  assert_message_contains("data[10] (voxel (1, 1, 0), channel 1) is nan");
  assert_int_equal(ht_tmpdir_entry_count(), 0);
}

static void count_mismatch_is_rejected_and_leaves_no_file(void **state) {
  hetinv_vol_header_t h = grid_header(2, 2, 1, 1);
  float v[5] = {0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_vol_write(*state, ht_path("n.vol"), &h, v, 5));
  assert_message_contains("count is 5; 2 x 2 x 1 voxels, channels 1, need 4 values");
  assert_int_equal(ht_tmpdir_entry_count(), 0);
}

static void missing_directory_is_an_io_error_and_leaves_no_file(void **state) {
  hetinv_vol_header_t h = grid_header(1, 1, 1, 1);
  const float v = 1.0f;
  assert_result(HETINV_ERROR_IO, hetinv_vol_write(*state, ht_path("no/such/dir.vol"), &h, &v, 1));
  assert_message_contains("no/such/dir.vol");
  assert_int_equal(ht_tmpdir_entry_count(), 0);
}

static void write_old_file(hetinv_context_t *ctx, const char *path) {
  hetinv_vol_header_t h = grid_header(2, 1, 1, 1);
  const float old[2] = {7.0f, 8.0f};
  assert_ok(hetinv_vol_write(ctx, path, &h, old, 2));
}

static void assert_old_file_intact(hetinv_context_t *ctx, const char *path) {
  hetinv_vol_header_t h;
  float back[2];
  assert_ok(hetinv_vol_read(ctx, path, &h, back, 2));
  assert_true(back[0] == 7.0f && back[1] == 8.0f);
  assert_int_equal(ht_tmpdir_entry_count(), 1);
}

static void rejected_write_keeps_the_existing_file(void **state) {
  const char *path = ht_path("keep.vol");
  write_old_file(*state, path);
  hetinv_vol_header_t h = grid_header(2, 1, 1, 1);
  const float v[2] = {1.0f, INFINITY};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_vol_write(*state, path, &h, v, 2));
  assert_old_file_intact(*state, path);
}

static void write_failing_midway_keeps_the_existing_file(void **state) {
  const char *path = ht_path("disk-full.vol");
  write_old_file(*state, path);
  /* A file size limit makes the OS refuse the write partway through. */
  struct rlimit old, small;
  assert_int_equal(getrlimit(RLIMIT_FSIZE, &old), 0);
  small = old;
  small.rlim_cur = 4096;
  void (*previous)(int) = signal(SIGXFSZ, SIG_IGN);
  assert_int_equal(setrlimit(RLIMIT_FSIZE, &small), 0);
  static float v[16 * 16 * 16];
  hetinv_vol_header_t h = grid_header(16, 16, 16, 1);
  hetinv_result_t r = hetinv_vol_write(*state, path, &h, v, 16 * 16 * 16);
  assert_int_equal(setrlimit(RLIMIT_FSIZE, &old), 0);
  signal(SIGXFSZ, previous);
  assert_int_equal(r, HETINV_ERROR_IO);
  assert_message_contains("disk-full.vol");
  assert_old_file_intact(*state, path);
}

/* ---- media -------------------------------------------------------------- */

static hetinv_medium_t *make_medium(hetinv_context_t *ctx, int32_t nx, int32_t ny, int32_t nz) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){-1.5, 0.0, 2.0}, (double[]){2.5, 1.0, 4.0},
                                 (int32_t[]){nx, ny, nz}, &m));
  return m;
}

static void medium_round_trip_keeps_values_and_box(void **state) {
  hetinv_medium_t *a = make_medium(*state, 3, 2, 2), *b = make_medium(*state, 3, 2, 2);
  double values[12];
  for (int i = 0; i < 12; ++i) values[i] = 0.25 * i;
  assert_ok(hetinv_medium_set_grid(a, HETINV_PARAM_SIGMA_A, values, 12));
  assert_ok(hetinv_medium_commit(a)); /* writing only reads the medium */
  const char *path = ht_path("sigma_a.vol");
  assert_ok(hetinv_medium_write_vol(a, HETINV_PARAM_SIGMA_A, path));
  assert_ok(hetinv_medium_read_vol(b, HETINV_PARAM_SIGMA_S, path));
  assert_memory_equal(hetinv_medium_grid(b, HETINV_PARAM_SIGMA_S), values, sizeof values);
  hetinv_vol_header_t h;
  assert_ok(hetinv_vol_read_header(*state, path, &h));
  assert_int_equal(h.channels, 1);
  assert_true(h.box_min[0] == -1.5 && h.box_max[0] == 2.5 && h.box_min[2] == 2.0 &&
              h.box_max[2] == 4.0);
  hetinv_medium_destroy(&a);
  hetinv_medium_destroy(&b);
}

static void medium_read_puts_x_fastest(void **state) {
  hetinv_medium_t *m = make_medium(*state, 2, 2, 2);
  assert_ok(hetinv_medium_read_vol(m, HETINV_PARAM_SIGMA_S, write_grid("x.vol", 2, 2, 2, 1, 8)));
  double s;
  assert_ok(hetinv_medium_get_voxel(m, 1, 0, 0, NULL, &s, NULL));
  assert_true(s == 1.0);
  assert_ok(hetinv_medium_get_voxel(m, 0, 1, 0, NULL, &s, NULL));
  assert_true(s == 2.0);
  assert_ok(hetinv_medium_get_voxel(m, 0, 0, 1, NULL, &s, NULL));
  assert_true(s == 4.0);
  hetinv_medium_destroy(&m);
}

static void medium_read_rejects_other_dims(void **state) {
  hetinv_medium_t *m = make_medium(*state, 2, 2, 2);
  const char *path = write_grid("d.vol", 2, 4, 1, 1, 8);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_medium_read_vol(m, HETINV_PARAM_G, path));
  assert_message_contains("holds 2 x 4 x 1 voxels, channels 1; the medium needs 2 x 2 x 2");
  hetinv_medium_destroy(&m);
}

static void medium_read_rejects_three_channels(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1, 1);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_read_vol(m, HETINV_PARAM_G, write_grid("rgb.vol", 1, 1, 1, 3, 3)));
  assert_message_contains("voxels, channels 3;");
  hetinv_medium_destroy(&m);
}

static void medium_read_rejects_an_invalid_value_naming_its_voxel(void **state) {
  hetinv_medium_t *m = make_medium(*state, 2, 2, 1);
  assert_ok(hetinv_medium_fill(m, 0.5, 0.5, 0.0));
  unsigned char h[HEADER];
  const float v[4] = {1.0f, 2.0f, 3.0f, -1.0f};
  make_header(h, 2, 2, 1, 1);
  const char *path = write_raw("negative.vol", h, HEADER, v, 4);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_read_vol(m, HETINV_PARAM_SIGMA_S, path));
  assert_message_contains("negative.vol': sigma_s of voxel (1, 1, 0) is -1; it must be >= 0");
  double s;
  assert_ok(hetinv_medium_get_voxel(m, 0, 0, 0, NULL, &s, NULL));
  assert_true(s == 0.5); /* unchanged */
  hetinv_medium_destroy(&m);
}

static void medium_read_passes_file_errors_on(void **state) {
  hetinv_medium_t *m = make_medium(*state, 2, 2, 2);
  const char *path = write_grid("c.vol", 2, 2, 2, 1, 7);
  assert_result(HETINV_ERROR_CORRUPT_FILE, hetinv_medium_read_vol(m, HETINV_PARAM_SIGMA_A, path));
  assert_message_contains("hetinv_medium_read_vol: '");
  assert_message_contains("truncated");
  hetinv_medium_destroy(&m);
}

static void medium_read_into_a_committed_medium_is_invalid_state(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1, 1);
  assert_ok(hetinv_medium_commit(m));
  const char *path = write_grid("one.vol", 1, 1, 1, 1, 1);
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_medium_read_vol(m, HETINV_PARAM_SIGMA_A, path));
  assert_message_contains("committed");
  hetinv_medium_destroy(&m);
}

static void medium_unknown_param_is_out_of_range(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1, 1);
  const char *path = write_grid("p.vol", 1, 1, 1, 1, 1);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_medium_read_vol(m, 3, path));
  assert_message_contains("param is 3");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_medium_write_vol(m, -1, ht_path("w.vol")));
  assert_message_contains("param is -1");
  assert_int_equal(ht_tmpdir_entry_count(), 1);
  hetinv_medium_destroy(&m);
}

static void medium_null_arguments_are_rejected(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1, 1);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_read_vol(NULL, 0, "x.vol"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_read_vol(m, 0, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_write_vol(NULL, 0, "x.vol"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_write_vol(m, 0, NULL));
  assert_message_contains("'path' is NULL");
  hetinv_medium_destroy(&m);
}

static void medium_g_near_one_is_written_readably(void **state) {
  hetinv_medium_t *a = make_medium(*state, 2, 1, 1), *b = make_medium(*state, 2, 1, 1);
  /* Both round to ±1 in float32, which the reader's g rule would reject. */
  assert_ok(hetinv_medium_set_grid(a, HETINV_PARAM_G, (double[]){1.0 - 1e-12, -1.0 + 1e-12}, 2));
  const char *path = ht_path("g.vol");
  assert_ok(hetinv_medium_write_vol(a, HETINV_PARAM_G, path));
  assert_ok(hetinv_medium_read_vol(b, HETINV_PARAM_G, path));
  const double *g = hetinv_medium_grid(b, HETINV_PARAM_G);
  assert_true(g[0] < 1.0 && g[0] > 0.9999);
  assert_true(g[1] > -1.0 && g[1] < -0.9999);
  hetinv_medium_destroy(&a);
  hetinv_medium_destroy(&b);
}

static void medium_value_beyond_float32_is_rejected_and_leaves_no_file(void **state) {
  hetinv_medium_t *m = make_medium(*state, 2, 1, 1);
  assert_ok(hetinv_medium_set_voxel(m, 1, 0, 0, 1e300, 0.0, 0.0));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_write_vol(m, HETINV_PARAM_SIGMA_A, ht_path("big.vol")));
  assert_message_contains("sigma_a of voxel (1, 0, 0) is 1e+300; it does not fit in float32");
  assert_int_equal(ht_tmpdir_entry_count(), 0);
  hetinv_medium_destroy(&m);
}

#define VOL_TEST(name) cmocka_unit_test_setup_teardown(name, setup, teardown)

int main(void) {
  const struct CMUnitTest tests[] = {
      VOL_TEST(one_channel_round_trip_keeps_values_and_box),
      VOL_TEST(three_channel_round_trip_keeps_values_and_box),
      VOL_TEST(written_file_has_the_mitsuba_byte_layout),
      VOL_TEST(hand_built_file_is_read_in_file_order),
      VOL_TEST(header_read_reports_dims_without_values),
      VOL_TEST(degenerate_box_is_accepted_by_the_reader),
      VOL_TEST(missing_file_is_an_io_error),
      VOL_TEST(directory_is_an_io_error),
      VOL_TEST(fifo_is_refused_without_waiting),
      VOL_TEST(empty_file_is_corrupt),
      VOL_TEST(truncated_header_is_corrupt),
      VOL_TEST(truncated_data_is_corrupt),
      VOL_TEST(wrong_magic_is_corrupt),
      VOL_TEST(version_2_is_unsupported),
      VOL_TEST(float16_encoding_is_unsupported),
      VOL_TEST(big_endian_file_is_named_as_such),
      VOL_TEST(uint8_and_direction_encodings_are_named),
      VOL_TEST(two_channels_are_unsupported),
      VOL_TEST(zero_dimension_is_corrupt),
      VOL_TEST(negative_dimension_is_corrupt),
      VOL_TEST(overflowing_dimensions_are_a_size_overflow),
      VOL_TEST(absurd_dimensions_with_a_tiny_file_fail_before_reading),
      VOL_TEST(non_finite_box_is_corrupt),
      VOL_TEST(inverted_box_is_corrupt),
      VOL_TEST(nan_value_is_corrupt_and_names_voxel_and_channel),
      VOL_TEST(infinite_value_is_corrupt),
      VOL_TEST(trailing_bytes_are_corrupt),
      VOL_TEST(too_small_capacity_is_an_invalid_argument),
      VOL_TEST(null_arguments_are_rejected),
      VOL_TEST(bad_header_is_rejected_and_leaves_no_file),
      VOL_TEST(overflowing_header_is_a_size_overflow),
      VOL_TEST(non_finite_value_is_rejected_naming_it_and_leaves_no_file),
      VOL_TEST(count_mismatch_is_rejected_and_leaves_no_file),
      VOL_TEST(missing_directory_is_an_io_error_and_leaves_no_file),
      VOL_TEST(rejected_write_keeps_the_existing_file),
      VOL_TEST(write_failing_midway_keeps_the_existing_file),
      VOL_TEST(medium_round_trip_keeps_values_and_box),
      VOL_TEST(medium_read_puts_x_fastest),
      VOL_TEST(medium_read_rejects_other_dims),
      VOL_TEST(medium_read_rejects_three_channels),
      VOL_TEST(medium_read_rejects_an_invalid_value_naming_its_voxel),
      VOL_TEST(medium_read_passes_file_errors_on),
      VOL_TEST(medium_read_into_a_committed_medium_is_invalid_state),
      VOL_TEST(medium_unknown_param_is_out_of_range),
      VOL_TEST(medium_null_arguments_are_rejected),
      VOL_TEST(medium_g_near_one_is_written_readably),
      VOL_TEST(medium_value_beyond_float32_is_rejected_and_leaves_no_file),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
