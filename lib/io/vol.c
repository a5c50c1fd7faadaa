/* Mitsuba binary grid volumes (.vol): parsing, reading and writing. */
#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <inttypes.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "io/vol_format.h"

_Static_assert(sizeof(float) == 4, "float must be IEEE 754 binary32");

enum { CHUNK_VALUES = 4096 }; /* values per buffered read or write (16 KiB) */

static const char *const dim_names[3] = {"xres", "yres", "zres"};
static const char axis_names[3] = {'x', 'y', 'z'};

/* Little-endian fields, assembled byte by byte so host byte order does not matter. */
static uint32_t get_u32(const unsigned char *p) {
  return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static int32_t get_i32(const unsigned char *p) {
  uint32_t u = get_u32(p);
  /* Two's complement without the implementation-defined unsigned → signed conversion. */
  return u <= INT32_MAX ? (int32_t)u : (int32_t)(u - 2147483648u) - INT32_MAX - 1;
}

static float get_f32(const unsigned char *p) {
  uint32_t u = get_u32(p);
  float f;
  memcpy(&f, &u, sizeof f);
  return f;
}

static void put_u32(unsigned char *p, uint32_t u) {
  p[0] = (unsigned char)(u & 0xffu);
  p[1] = (unsigned char)(u >> 8 & 0xffu);
  p[2] = (unsigned char)(u >> 16 & 0xffu);
  p[3] = (unsigned char)(u >> 24);
}

static void put_f32(unsigned char *p, float f) {
  uint32_t u;
  memcpy(&u, &f, sizeof u);
  put_u32(p, u);
}

static const char *encoding_name(int32_t encoding) {
  switch (encoding) {
    case 1: return "float32";
    case 2: return "float16";
    case 3: return "uint8";
    case 4: return "quantized directions";
    default: return "unknown";
  }
}

/* dims·channels values and their size in bytes, or SIZE_OVERFLOW. */
static hetinv_result_t value_count(const hetinv_context_t *ctx,
                                   const char *source, const hetinv_vol_header_t *h,
                                   size_t *count) {
  size_t n = (size_t)h->channels, bytes;
  bool ok = hv_mul_size(n, (size_t)h->dims[0], &n) && hv_mul_size(n, (size_t)h->dims[1], &n) &&
            hv_mul_size(n, (size_t)h->dims[2], &n) && hv_mul_size(n, sizeof(float), &bytes);
  if (!ok) {
    return HV_FAIL(ctx, HETINV_ERROR_SIZE_OVERFLOW,
                   "%s: %d x %d x %d voxels, channels %d, overflow size_t", source,
                   (int)h->dims[0], (int)h->dims[1], (int)h->dims[2], (int)h->channels);
  }
  *count = n;
  return HETINV_SUCCESS;
}

hetinv_result_t hv_vol_parse_header(const hetinv_context_t *ctx,
                                    const char *source, const unsigned char *bytes, size_t size,
                                    uint64_t file_size, hetinv_vol_header_t *header,
                                    size_t *value_count_out) {
  memset(header, 0, sizeof *header);
  *value_count_out = 0;
  if (size == 0 || file_size == 0) {
    return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                   "%s is empty; a .vol file starts with a %d-byte header", source,
                   HV_VOL_HEADER_SIZE);
  }
  if (memcmp(bytes, "VOL", size < 3 ? size : 3) != 0) {
    char magic[16] = "";
    for (size_t i = 0; i < 3 && i < size; ++i) {
      snprintf(magic + 4 * i, sizeof magic - 4 * i, "\\x%02x", (unsigned)bytes[i]);
    }
    return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                   "%s is not a .vol file: it starts with \"%s\", not \"VOL\"", source, magic);
  }
  if (size > 3 && bytes[3] != 3) {
    return HV_FAIL(ctx, HETINV_ERROR_UNSUPPORTED,
                   "%s has .vol version %u; only version 3 is supported", source,
                   (unsigned)bytes[3]);
  }
  if (size < HV_VOL_HEADER_SIZE) {
    return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                   "%s is truncated: the header needs %d bytes, there are %zu", source,
                   HV_VOL_HEADER_SIZE, size);
  }
  int32_t encoding = get_i32(bytes + 4);
  if (encoding != 1) {
    /* An encoding that reads as one of the four with its bytes reversed:
     * a big-endian writer's file. */
    uint32_t u = (uint32_t)encoding, swapped = u >> 24 | (u >> 8 & 0xff00u) | (u << 8 & 0xff0000u) | u << 24;
    bool big_endian = swapped >= 1 && swapped <= 4;
    return HV_FAIL(ctx, HETINV_ERROR_UNSUPPORTED,
                   "%s: encoding is %d (%s); only 1 (float32) is supported%s", source,
                   (int)encoding, encoding_name(encoding),
                   big_endian ? ": the file looks big-endian, and .vol files are little-endian" : "");
  }
  hetinv_vol_header_t h;
  for (int i = 0; i < 3; ++i) h.dims[i] = get_i32(bytes + 8 + 4 * i);
  h.channels = get_i32(bytes + 20);
  if (h.channels != 1 && h.channels != 3) {
    return HV_FAIL(ctx, HETINV_ERROR_UNSUPPORTED,
                   "%s: channels is %d; only 1 or 3 are supported", source, (int)h.channels);
  }
  for (int i = 0; i < 3; ++i) {
    if (h.dims[i] <= 0) {
      return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "%s: %s is %d; it must be > 0",
                     source, dim_names[i], (int)h.dims[i]);
    }
  }
  for (int i = 0; i < 3; ++i) {
    h.box_min[i] = (double)get_f32(bytes + 24 + 4 * i);
    h.box_max[i] = (double)get_f32(bytes + 36 + 4 * i);
    if (!isfinite(h.box_min[i]) || !isfinite(h.box_max[i]) || h.box_min[i] > h.box_max[i]) {
      /* A degenerate box (min == max) occurs in real Mitsuba files and is accepted. */
      return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                     "%s: the box along %c is [%g, %g]; both ends must be finite and min <= max",
                     source, axis_names[i], h.box_min[i], h.box_max[i]);
    }
  }
  size_t count = 0;
  hetinv_result_t r = value_count(ctx, source, &h, &count);
  if (r != HETINV_SUCCESS) return r;
  /* Compared with the file's length before anyone allocates for the values. */
  uint64_t need = (uint64_t)count * sizeof(float), have = file_size - HV_VOL_HEADER_SIZE;
  if (file_size < HV_VOL_HEADER_SIZE || need > have) {
    return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                   "%s is truncated: the header says %zu values (%" PRIu64
                   " bytes), the file holds %" PRIu64 " bytes after the header",
                   source, count, need, file_size < HV_VOL_HEADER_SIZE ? 0 : have);
  }
  if (need < have) {
    return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                   "%s has %" PRIu64 " trailing bytes after the %zu values the header announces",
                   source, have - need, count);
  }
  *header = h;
  *value_count_out = count;
  return HETINV_SUCCESS;
}

hetinv_result_t hv_vol_decode_values(const hetinv_context_t *ctx,
                                     const char *source, const hetinv_vol_header_t *header,
                                     const unsigned char *bytes, size_t first, size_t n,
                                     float *out) {
  for (size_t k = 0; k < n; ++k) {
    float v = get_f32(bytes + 4 * k);
    if (!isfinite(v)) {
      size_t i = first + k, ch = (size_t)header->channels, voxel = i / ch;
      size_t nx = (size_t)header->dims[0], ny = (size_t)header->dims[1];
      return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                     "%s: the value of voxel (%zu, %zu, %zu), channel %zu is %g; values must "
                     "be finite",
                     source, voxel % nx, voxel / nx % ny, voxel / (nx * ny), i % ch, (double)v);
    }
    out[k] = v;
  }
  return HETINV_SUCCESS;
}

static hetinv_result_t check_capacity(const hetinv_context_t *ctx,
                                      const char *source, size_t count, size_t capacity) {
  if (capacity >= count) return HETINV_SUCCESS;
  return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                 "capacity is %zu floats; %s holds %zu values", capacity, source, count);
}

hetinv_result_t hv_vol_parse(const hetinv_context_t *ctx, const char *source,
                             const unsigned char *bytes, size_t size, hetinv_vol_header_t *header,
                             float *data, size_t capacity) {
  hetinv_vol_header_t h;
  size_t count;
  memset(header, 0, sizeof *header);
  hetinv_result_t r = hv_vol_parse_header(ctx, source, bytes, size, size, &h, &count);
  if (r == HETINV_SUCCESS && data != NULL) {
    r = check_capacity(ctx, source, count, capacity);
    if (r == HETINV_SUCCESS) {
      r = hv_vol_decode_values(ctx, source, &h, bytes + HV_VOL_HEADER_SIZE, 0, count, data);
    }
  }
  if (r == HETINV_SUCCESS) *header = h;
  return r;
}

/* Streams the values after the header through a small buffer. The file's
 * size was checked, but it may change while we read. */
static hetinv_result_t read_values(const hetinv_context_t *ctx,
                                   const char *source, FILE *fp, const hetinv_vol_header_t *h,
                                   size_t count, float *data) {
  unsigned char buf[CHUNK_VALUES * 4];
  for (size_t done = 0; done < count;) {
    size_t n = count - done < CHUNK_VALUES ? count - done : CHUNK_VALUES;
    if (fread(buf, 4, n, fp) != n) {
      if (ferror(fp)) {
        return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot read %s: %s", source, strerror(errno));
      }
      return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                     "%s is truncated: it ended while being read, before value %zu of %zu",
                     source, done, count);
    }
    hetinv_result_t r = hv_vol_decode_values(ctx, source, h, buf, done, n, data + done);
    if (r != HETINV_SUCCESS) return r;
    done += n;
  }
  if (fgetc(fp) != EOF) {
    return HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                   "%s has trailing bytes after the %zu values the header announces", source,
                   count);
  }
  return HETINV_SUCCESS;
}

/* hv_vol_read_file's work on an open file; @p source is "'<path>'". */
static hetinv_result_t read_open_file(const hetinv_context_t *ctx,
                                      const char *source, FILE *fp, hetinv_vol_header_t *h,
                                      float *data, size_t capacity) {
  struct stat st;
  if (fstat(fileno(fp), &st) != 0) {
    return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot stat %s: %s", source, strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    return HV_FAIL(ctx, HETINV_ERROR_IO, "%s is not a regular file", source);
  }
  unsigned char head[HV_VOL_HEADER_SIZE];
  size_t got = fread(head, 1, sizeof head, fp);
  if (ferror(fp)) {
    return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot read %s: %s", source, strerror(errno));
  }
  size_t count;
  hetinv_result_t r =
      hv_vol_parse_header(ctx, source, head, got, (uint64_t)st.st_size, h, &count);
  if (r != HETINV_SUCCESS || data == NULL) return r;
  r = check_capacity(ctx, source, count, capacity);
  if (r != HETINV_SUCCESS) return r;
  return read_values(ctx, source, fp, h, count, data);
}

hetinv_result_t hv_vol_read_file(const hetinv_context_t *ctx, const char *path,
                                 hetinv_vol_header_t *header, float *data, size_t capacity) {
  char source[1024];
  snprintf(source, sizeof source, "'%s'", path);
  memset(header, 0, sizeof *header);
  /* O_NONBLOCK: the open of a FIFO does not wait for a writer (refused
   * below); reads of a regular file are unchanged by it. */
  int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot open %s: %s", source, strerror(errno));
  struct stat st;
  const char *why = fstat(fd, &st) != 0 ? strerror(errno) : S_ISREG(st.st_mode) ? NULL : "it is not a regular file";
  if (why != NULL) {
    hetinv_result_t failed = HV_FAIL(ctx, HETINV_ERROR_IO, "cannot read %s: %s", source, why);
    close(fd);
    return failed;
  }
  FILE *fp = fdopen(fd, "rb");
  if (fp == NULL) {
    int err = errno;
    close(fd);
    return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot open %s: %s", source, strerror(err));
  }
  hetinv_vol_header_t h;
  hetinv_result_t r = read_open_file(ctx, source, fp, &h, data, capacity);
  fclose(fp);
  if (r == HETINV_SUCCESS) *header = h;
  return r;
}

/* The header rules of hetinv_vol_write(); sets *count = dims·channels. */
static hetinv_result_t check_header(const hetinv_context_t *ctx,
                                    const hetinv_vol_header_t *h, size_t *count) {
  for (int i = 0; i < 3; ++i) {
    if (h->dims[i] <= 0) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "header->dims[%d] (%s) is %d; it must be > 0", i, dim_names[i],
                     (int)h->dims[i]);
    }
  }
  if (h->channels != 1 && h->channels != 3) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "header->channels is %d; it must be 1 or 3", (int)h->channels);
  }
  for (int i = 0; i < 3; ++i) {
    double lo = h->box_min[i], hi = h->box_max[i];
    /* fabs() <= FLT_MAX also rejects NaN and keeps the float conversion defined. */
    /* Compared as stored: [1, 1 + 1e-12] is [1, 1] in float32. */
    if (!(fabs(lo) <= (double)FLT_MAX) || !(fabs(hi) <= (double)FLT_MAX) || !((float)lo < (float)hi)) {
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "the box along %c is [%.9g, %.9g]; both ends must be finite float32 values "
                     "and box_min < box_max in float32",
                     axis_names[i], lo, hi);
    }
  }
  return value_count(ctx, "the header", h, count);
}

static hetinv_result_t write_payload(const hetinv_context_t *ctx,
                                     const char *path, FILE *fp, const hetinv_vol_header_t *h,
                                     const float *data, size_t count) {
  unsigned char buf[CHUNK_VALUES * 4];
  memcpy(buf, "VOL\3", 4);
  put_u32(buf + 4, 1); /* float32 encoding */
  for (int i = 0; i < 3; ++i) put_u32(buf + 8 + 4 * i, (uint32_t)h->dims[i]);
  put_u32(buf + 20, (uint32_t)h->channels);
  for (int i = 0; i < 3; ++i) {
    put_f32(buf + 24 + 4 * i, (float)h->box_min[i]);
    put_f32(buf + 36 + 4 * i, (float)h->box_max[i]);
  }
  bool ok = fwrite(buf, 1, HV_VOL_HEADER_SIZE, fp) == HV_VOL_HEADER_SIZE;
  for (size_t done = 0; ok && done < count;) {
    size_t n = count - done < CHUNK_VALUES ? count - done : CHUNK_VALUES;
    for (size_t k = 0; k < n; ++k) put_f32(buf + 4 * k, data[done + k]);
    ok = fwrite(buf, 4, n, fp) == n;
    done += n;
  }
  if (ok) return HETINV_SUCCESS;
  return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot write '%s': %s", path,
                 strerror(errno ? errno : EIO));
}

hetinv_result_t hv_vol_write_file(const hetinv_context_t *ctx, const char *path,
                                  const hetinv_vol_header_t *header, const float *data,
                                  size_t count) {
  size_t expected = 0;
  hetinv_result_t r = check_header(ctx, header, &expected);
  if (r != HETINV_SUCCESS) return r;
  if (count != expected) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "count is %zu; %d x %d x %d voxels, channels %d, need %zu values", count,
                   (int)header->dims[0], (int)header->dims[1], (int)header->dims[2],
                   (int)header->channels, expected);
  }
  size_t ch = (size_t)header->channels, nx = (size_t)header->dims[0],
         ny = (size_t)header->dims[1];
  for (size_t i = 0; i < count; ++i) {
    if (!isfinite(data[i])) {
      size_t voxel = i / ch;
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "data[%zu] (voxel (%zu, %zu, %zu), channel %zu) is %g; values must be "
                     "finite",
                     i, voxel % nx, voxel / nx % ny, voxel / (nx * ny), i % ch, (double)data[i]);
    }
  }
  hv_atomic_file_t f;
  r = hv_atomic_open(ctx, path, 1, &f);
  if (r != HETINV_SUCCESS) return r;
  r = write_payload(ctx, path, f.fp, header, data, count);
  if (r != HETINV_SUCCESS) {
    hv_atomic_abort(&f);
    return r;
  }
  return hv_atomic_commit(&f);
}

HETINV_API hetinv_result_t hetinv_vol_read_header(hetinv_context_t *ctx, const char *path,
                                                  hetinv_vol_header_t *header) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, header);
  memset(header, 0, sizeof *header);
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, path);
  return hv_vol_read_file(ctx, path, header, NULL, 0);
}

HETINV_API hetinv_result_t hetinv_vol_read(hetinv_context_t *ctx, const char *path,
                                           hetinv_vol_header_t *header, float *data,
                                           size_t capacity) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, header);
  memset(header, 0, sizeof *header);
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, path);
  HV_CHECK_NULL(ctx, data);
  return hv_vol_read_file(ctx, path, header, data, capacity);
}

HETINV_API hetinv_result_t hetinv_vol_write(hetinv_context_t *ctx, const char *path,
                                            const hetinv_vol_header_t *header, const float *data,
                                            size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, path);
  HV_CHECK_NULL(ctx, header);
  HV_CHECK_NULL(ctx, data);
  return hv_vol_write_file(ctx, path, header, data, count);
}
