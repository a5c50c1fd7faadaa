#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/image_internal.h"

/* A file may claim at most this many bytes of pixels per byte it holds: well
 * above what any OpenEXR compression achieves, so that a header with an
 * absurd data window fails before the image is allocated. */
enum { MAX_COMPRESSION_RATIO = 65536 };

/* ---- OpenEXR messages (shared with exr_write.c) ------------------------- */

static _Thread_local char exr_message[512];

void hv_exr_record_error(exr_const_context_t exr, exr_result_t code, const char *message) {
  (void)exr, (void)code;
  /* The first message is the precise one; later ones wrap it ("unable to ..."). */
  if (exr_message[0] == '\0' && message != NULL) {
    snprintf(exr_message, sizeof exr_message, "%s", message);
  }
}

void hv_exr_clear_error(void) { exr_message[0] = '\0'; }

const char *hv_exr_error_message(exr_result_t code) {
  return exr_message[0] != '\0' ? exr_message : exr_get_default_error_message(code);
}

/* ---- the read ------------------------------------------------------------ */

typedef struct exr_reader {
  hetinv_context_t *ctx;
  const char *path;
  int fd;
  int64_t file_size;
  int os_error; /* errno of a failed read */
  exr_context_t exr;
  exr_storage_t storage;
  exr_attr_box2i_t window;
  int32_t width, height;
  const exr_attr_chlist_t *channels;
  int32_t *file_to_image; /* channel k of the file is image channel file_to_image[k] */
  hetinv_image_t *image;
  exr_result_t (*decompress)(exr_decode_pipeline_t *); /* OpenEXR's own */
  char where[96]; /* "chunk 3 (...): " while a chunk is read, else "" */
} exr_reader_t;

/* Maps an OpenEXR failure to our codes; names the chunk if one is being read. */
static hetinv_result_t fail_exr(const exr_reader_t *rd, exr_result_t rv) {
  const char *what = hv_exr_error_message(rv), *name = exr_get_error_code_as_string(rv);
  const char *where = rd->where;
  switch (rv) {
    case EXR_ERR_OUT_OF_MEMORY:
      return HV_FAIL(rd->ctx, HETINV_ERROR_OUT_OF_MEMORY, "'%s': %s%s", rd->path, where, what);
    case EXR_ERR_FILE_ACCESS:
      return HV_FAIL(rd->ctx, HETINV_ERROR_IO, "cannot read '%s': %s%s", rd->path, where, what);
    case EXR_ERR_FEATURE_NOT_IMPLEMENTED:
      return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                     "'%s' uses an unsupported feature: %s%s", rd->path, where, what);
    case EXR_ERR_READ_IO:
      if (rd->os_error != 0) {
        return HV_FAIL(rd->ctx, HETINV_ERROR_IO, "cannot read '%s': %s%s", rd->path, where,
                       strerror(rd->os_error));
      }
      /* a short read of an intact file: it is truncated */
      return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE, "'%s' is truncated: %s%s (%s)",
                     rd->path, where, what, name);
    default: /* everything else comes from the file's content */
      return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE,
                     "'%s' is not a valid OpenEXR file: %s%s (%s)", rd->path, where, what, name);
  }
}

/* OpenEXR's read callback: pread of the open file; short at the end of file. */
static int64_t read_source(exr_const_context_t exr, void *user, void *buffer, uint64_t size,
                           uint64_t offset, exr_stream_error_func_ptr_t error_cb) {
  (void)exr, (void)error_cb;
  exr_reader_t *rd = user;
  uint64_t end = (uint64_t)rd->file_size;
  if (offset >= end) return 0;
  if (size > end - offset) size = end - offset;
  uint64_t done = 0;
  while (done < size) {
    size_t want = size - done > (1u << 30) ? (size_t)1 << 30 : (size_t)(size - done);
    ssize_t n = pread(rd->fd, (uint8_t *)buffer + done, want, (off_t)(offset + done));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      rd->os_error = errno;
      return -1;
    }
    if (n == 0) break;
    done += (uint64_t)n;
  }
  return (int64_t)done;
}

static int64_t size_source(exr_const_context_t exr, void *user) {
  (void)exr;
  return ((const exr_reader_t *)user)->file_size;
}

/* Opens the file and parses its header. */
static hetinv_result_t open_file(exr_reader_t *rd) {
  /* O_NONBLOCK: the open of a FIFO does not wait for a writer (refused
   * below); reads of a regular file are unchanged by it. */
  rd->fd = open(rd->path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (rd->fd < 0) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_IO, "cannot open '%s': %s", rd->path, strerror(errno));
  }
  struct stat st;
  if (fstat(rd->fd, &st) != 0) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_IO, "cannot stat '%s': %s", rd->path, strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_IO, "'%s' is not a regular file", rd->path);
  }
  rd->file_size = (int64_t)st.st_size;
  if (rd->file_size == 0) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE, "'%s' is empty", rd->path);
  }
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = hv_exr_record_error;
  init.user_data = rd;
  init.read_fn = read_source;
  init.size_fn = size_source;
  /* A damaged chunk table is an error, not something to search around. */
  init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
  exr_result_t rv = exr_start_read(&rd->exr, rd->path, &init);
  return rv == EXR_ERR_SUCCESS ? HETINV_SUCCESS : fail_exr(rd, rv);
}

/* A multi-part file is refused rather than read by its first part: that
 * part may be another tool's preview or dark frame with the same channels. */
static hetinv_result_t check_single_part(exr_reader_t *rd) {
  int parts = 0;
  exr_result_t rv = exr_get_count(rd->exr, &parts);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  if (parts == 1) return HETINV_SUCCESS;
  const char *first = NULL, *second = NULL;
  if (exr_get_name(rd->exr, 0, &first) != EXR_ERR_SUCCESS || first == NULL) first = "";
  if (parts < 2 || exr_get_name(rd->exr, 1, &second) != EXR_ERR_SUCCESS || second == NULL) second = "";
  hv_exr_clear_error();
  return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                 "'%s' has %d parts (the first two named \"%.64s\" and \"%.64s\"); only single-part "
                 "files are read: save the part that holds the image as a file of its own",
                 rd->path, parts, first, second);
}

/* The image is the data window, so it must be the display window too: a
 * window offset from it (a crop, an overscan) would be read shifted. */
static hetinv_result_t check_windows(exr_reader_t *rd) {
  exr_attr_box2i_t display;
  exr_result_t rv = exr_get_display_window(rd->exr, 0, &display);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  const exr_attr_box2i_t *w = &rd->window;
  if (display.min.x == w->min.x && display.min.y == w->min.y && display.max.x == w->max.x &&
      display.max.y == w->max.y) {
    return HETINV_SUCCESS;
  }
  return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                 "the data window of '%s', (%d, %d) - (%d, %d), is not its display window, (%d, %d) - "
                 "(%d, %d); only files whose two windows are the same are read (a cropped or "
                 "overscanned image would be read shifted)",
                 rd->path, (int)w->min.x, (int)w->min.y, (int)w->max.x, (int)w->max.y, (int)display.min.x,
                 (int)display.min.y, (int)display.max.x, (int)display.max.y);
}

/* OpenEXR's C core decodes DWAA and DWAB from 3.1.10 on; before, only the
 * chunks stored raw would read, so a file would pass or fail by its
 * content. Refused whole instead, by the library actually loaded. */
static hetinv_result_t check_compression(exr_reader_t *rd) {
  exr_compression_t compression = EXR_COMPRESSION_NONE;
  exr_result_t rv = exr_get_compression(rd->exr, 0, &compression);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  if (compression != EXR_COMPRESSION_DWAA && compression != EXR_COMPRESSION_DWAB) return HETINV_SUCCESS;
  int major = 0, minor = 0, patch = 0;
  const char *extra = NULL;
  exr_get_library_version(&major, &minor, &patch, &extra);
  if (major > 3 || (major == 3 && (minor > 1 || (minor == 1 && patch >= 10)))) return HETINV_SUCCESS;
  return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                 "'%s' is %s-compressed, which the OpenEXR library in use (%d.%d.%d) cannot decode "
                 "(3.1.10 and later can): save it with ZIP or PIZ compression",
                 rd->path, compression == EXR_COMPRESSION_DWAA ? "DWAA" : "DWAB", major, minor, patch);
}

/* Checks what we support and that the data window is sane before allocating. */
static hetinv_result_t check_header(exr_reader_t *rd) {
  hetinv_result_t r = check_single_part(rd);
  if (r != HETINV_SUCCESS) return r;
  exr_result_t rv = exr_get_storage(rd->exr, 0, &rd->storage);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_channels(rd->exr, 0, &rd->channels);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_data_window(rd->exr, 0, &rd->window);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  if (rd->storage == EXR_STORAGE_DEEP_SCANLINE || rd->storage == EXR_STORAGE_DEEP_TILED) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                   "'%s' holds deep data; only flat images are supported", rd->path);
  }
  const exr_attr_chlist_t *list = rd->channels;
  if (list->num_channels <= 0 || list->num_channels > INT16_MAX) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                   "'%s' has %d channels; 1 to %d are supported", rd->path, list->num_channels,
                   INT16_MAX);
  }
  uint64_t bytes_per_pixel = 0;
  for (int k = 0; k < list->num_channels; ++k) {
    const exr_attr_chlist_entry_t *e = &list->entries[k];
    if (e->x_sampling != 1 || e->y_sampling != 1) {
      return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                     "channel \"%s\" of '%s' is subsampled (%d x %d); only full-resolution "
                     "channels are supported",
                     e->name.str, rd->path, (int)e->x_sampling, (int)e->y_sampling);
    }
    if (e->pixel_type != EXR_PIXEL_HALF && e->pixel_type != EXR_PIXEL_FLOAT &&
        e->pixel_type != EXR_PIXEL_UINT) {
      return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE,
                     "channel \"%s\" of '%s' has pixel type %d", e->name.str, rd->path,
                     (int)e->pixel_type);
    }
    if (!hv_image_name_is_valid(e->name.str)) {
      return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED,
                     "channel %d of '%s' has a name that is not printable ASCII", k, rd->path);
    }
    bytes_per_pixel += e->pixel_type == EXR_PIXEL_HALF ? 2 : 4;
  }
  const exr_attr_box2i_t *w = &rd->window;
  int64_t width = (int64_t)w->max.x - w->min.x + 1, height = (int64_t)w->max.y - w->min.y + 1;
  if (width <= 0 || height <= 0) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE,
                   "the data window of '%s' is (%d, %d) - (%d, %d): empty", rd->path,
                   (int)w->min.x, (int)w->min.y, (int)w->max.x, (int)w->max.y);
  }
  /* First: a header claiming more pixels than its file can hold is corrupt. */
  if ((double)width * (double)height * (double)bytes_per_pixel >
      (double)rd->file_size * MAX_COMPRESSION_RATIO) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE,
                   "'%s' claims %lld x %lld pixels of %d channels but holds only %lld bytes",
                   rd->path, (long long)width, (long long)height, list->num_channels,
                   (long long)rd->file_size);
  }
  size_t pixels, floats, bytes;
  if (!hv_mul_size((size_t)width, (size_t)height, &pixels) ||
      !hv_mul_size(pixels, (size_t)list->num_channels, &floats) ||
      !hv_mul_size(floats, sizeof(float), &bytes)) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_SIZE_OVERFLOW,
                   "'%s' has %lld x %lld pixels of %d channels: more floats than fit in memory",
                   rd->path, (long long)width, (long long)height, list->num_channels);
  }
  /* The decoder's line stride (width·4 bytes) is an int32. */
  if (width > INT32_MAX / (int64_t)sizeof(float) || height > INT32_MAX) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_SIZE_OVERFLOW,
                   "the data window of '%s' is %lld x %lld pixels; rows of more than %d floats "
                   "cannot be read",
                   rd->path, (long long)width, (long long)height,
                   (int)(INT32_MAX / (int)sizeof(float)));
  }
  /* After the size checks: a window the file cannot hold is corrupt first. */
  if ((r = check_windows(rd)) != HETINV_SUCCESS || (r = check_compression(rd)) != HETINV_SUCCESS) return r;
  rd->width = (int32_t)width;
  rd->height = (int32_t)height;
  return HETINV_SUCCESS;
}

/* Names the image's channels, in HV_EXR_CHANNEL_ORDER's order when the file
 * has a valid one (a permutation of its channels), else in the file's order. */
static hetinv_result_t order_channels(exr_reader_t *rd) {
  int32_t n = rd->channels->num_channels;
  const char **names = hv_calloc(rd->ctx, (size_t)n, sizeof *names);
  rd->file_to_image = hv_calloc(rd->ctx, (size_t)n, sizeof(int32_t));
  hv_name_index_t *index = NULL;
  if (names != NULL) {
    for (int32_t k = 0; k < n; ++k) names[k] = rd->channels->entries[k].name.str;
    index = hv_name_index_build(rd->ctx, names, n);
  }
  hetinv_result_t r = HETINV_SUCCESS;
  if (index == NULL || rd->file_to_image == NULL) {
    r = HV_FAIL(rd->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a table of %d channels",
                (int)n);
  }
  for (int32_t k = 1; r == HETINV_SUCCESS && k < n; ++k) { /* sorted: duplicates are adjacent */
    if (strcmp(index[k - 1].name, index[k].name) == 0) {
      r = HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE, "'%s' has two channels called \"%s\"",
                  rd->path, index[k].name);
    }
  }
  if (r == HETINV_SUCCESS) {
    for (int32_t k = 0; k < n; ++k) rd->file_to_image[k] = k;
    const exr_attribute_t *order = NULL;
    if (exr_get_attribute_by_name(rd->exr, 0, HV_EXR_CHANNEL_ORDER, &order) == EXR_ERR_SUCCESS &&
        order->type == EXR_ATTR_STRING_VECTOR && order->stringvector->n_strings == n) {
      bool valid = true;
      for (int32_t k = 0; k < n; ++k) rd->file_to_image[k] = -1;
      for (int32_t i = 0; valid && i < n; ++i) {
        int32_t k = hv_name_index_find(index, n, order->stringvector->strings[i].str);
        valid = k >= 0 && rd->file_to_image[k] < 0;
        if (valid) rd->file_to_image[k] = i;
      }
      for (int32_t k = 0; !valid && k < n; ++k) rd->file_to_image[k] = k;
    }
    hv_exr_clear_error(); /* OpenEXR reports a missing attribute as an error */
  }
  for (int32_t k = 0; r == HETINV_SUCCESS && k < n; ++k) {
    r = hv_image_store_channel_name(rd->image, rd->file_to_image[k], names[k]);
  }
  hv_free(rd->ctx, index);
  hv_free(rd->ctx, names);
  return r;
}

/* Copies the string, float, double and int attributes the image can hold;
 * structural ones and anything else are skipped. */
static hetinv_result_t load_attributes(exr_reader_t *rd) {
  int32_t count = 0;
  exr_result_t rv = exr_get_attribute_count(rd->exr, 0, &count);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  for (int32_t i = 0; i < count; ++i) {
    const exr_attribute_t *a = NULL;
    rv = exr_get_attribute_by_index(rd->exr, 0, EXR_ATTR_LIST_FILE_ORDER, i, &a);
    if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
    if (!hv_image_name_is_valid(a->name) || hv_image_attribute_is_reserved(a->name)) continue;
    hetinv_result_t r = HETINV_SUCCESS;
    if (a->type == EXR_ATTR_STRING) {
      const exr_attr_string_t *s = a->string;
      /* skipped if too long for set_attribute_string or with an embedded NUL */
      if (s->length < 0 || s->length > HV_IMAGE_STRING_MAX ||
          strnlen(s->str, (size_t)s->length + 1) != (size_t)s->length) {
        continue;
      }
      r = hv_image_store_attribute(rd->image, a->name, HETINV_ATTRIBUTE_STRING, s->str, 0.0,
                                   0);
    } else if ((a->type == EXR_ATTR_FLOAT && isfinite(a->f)) ||
               (a->type == EXR_ATTR_DOUBLE && isfinite(a->d))) {
      double value = a->type == EXR_ATTR_FLOAT ? (double)a->f : a->d;
      r = hv_image_store_attribute(rd->image, a->name, HETINV_ATTRIBUTE_DOUBLE, NULL, value,
                                   0);
    } else if (a->type == EXR_ATTR_INT) {
      r = hv_image_store_attribute(rd->image, a->name, HETINV_ATTRIBUTE_INT, NULL, 0.0, a->i);
    }
    if (r != HETINV_SUCCESS) return r;
  }
  return HETINV_SUCCESS;
}

/* ---- pixels -------------------------------------------------------------- */

static float half_to_float(uint16_t h) {
  int exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
  float v;
  if (exponent == 0) {
    v = ldexpf((float)mantissa, -24); /* zero or subnormal */
  } else if (exponent == 31) {
    v = mantissa != 0 ? NAN : INFINITY;
  } else {
    v = ldexpf((float)(mantissa | 0x400), exponent - 25);
  }
  return (h & 0x8000) != 0 ? -v : v;
}

/* Our unpack step of OpenEXR's decoder: the decompressed chunk holds, row by
 * row, each channel's samples little-endian; convert them to float. Ours
 * rather than OpenEXR's so that every version converts the same way. */
static exr_result_t unpack_to_float(exr_decode_pipeline_t *dec) {
  const uint8_t *src = dec->unpacked_buffer;
  uint64_t needed = 0;
  for (int c = 0; c < dec->channel_count; ++c) {
    const exr_coding_channel_info_t *ch = &dec->channels[c];
    if (ch->width != dec->chunk.width || ch->height != dec->chunk.height) {
      return EXR_ERR_CORRUPT_CHUNK;
    }
    needed += (uint64_t)ch->width * (uint64_t)ch->height * (uint64_t)ch->bytes_per_element;
  }
  if (src == NULL || needed != dec->chunk.unpacked_size) return EXR_ERR_CORRUPT_CHUNK;
  for (int32_t y = 0; y < dec->chunk.height; ++y) {
    for (int c = 0; c < dec->channel_count; ++c) {
      const exr_coding_channel_info_t *ch = &dec->channels[c];
      float *dst = (float *)(void *)(ch->decode_to_ptr + (size_t)y * (size_t)ch->user_line_stride);
      for (int32_t x = 0; x < ch->width; ++x) {
        if (ch->data_type == EXR_PIXEL_HALF) {
          dst[x] = half_to_float((uint16_t)(src[0] | src[1] << 8));
          src += 2;
          continue;
        }
        uint32_t bits = (uint32_t)src[0] | (uint32_t)src[1] << 8 | (uint32_t)src[2] << 16 |
                        (uint32_t)src[3] << 24;
        src += 4;
        if (ch->data_type == EXR_PIXEL_FLOAT) {
          memcpy(&dst[x], &bits, sizeof bits);
        } else {
          dst[x] = (float)bits;
        }
      }
    }
  }
  return EXR_ERR_SUCCESS;
}

/* A chunk that would not shrink is stored raw, whatever the compression (the
 * C++ library reads it so); OpenEXR 3.1's core still runs B44 on it and fails. */
static exr_result_t decompress(exr_decode_pipeline_t *dec) {
  if (dec->chunk.packed_size != dec->chunk.unpacked_size) {
    return ((const exr_reader_t *)dec->decoding_user_data)->decompress(dec);
  }
  if (dec->unpacked_buffer != dec->packed_buffer) {
    memcpy(dec->unpacked_buffer, dec->packed_buffer, dec->chunk.unpacked_size);
  }
  return EXR_ERR_SUCCESS;
}

/* Decodes one chunk whose top-left pixel is (x0, y0) of the image. */
static hetinv_result_t decode_chunk(exr_reader_t *rd, exr_decode_pipeline_t *dec, bool *started,
                                    const exr_chunk_info_t *chunk, int64_t x0, int64_t y0) {
  if (chunk->width <= 0 || chunk->height <= 0 || x0 < 0 || y0 < 0 ||
      x0 + chunk->width > rd->width || y0 + chunk->height > rd->height) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE,
                   "'%s': chunk %d (%d x %d pixels at %lld, %lld) does not fit the %d x %d image",
                   rd->path, (int)chunk->idx, (int)chunk->width, (int)chunk->height,
                   (long long)x0, (long long)y0, (int)rd->width, (int)rd->height);
  }
  if (chunk->packed_size == 0) { /* OpenEXR would leave the pixels undefined */
    return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE, "'%s': chunk %d holds no data",
                   rd->path, (int)chunk->idx);
  }
  snprintf(rd->where, sizeof rd->where, "chunk %d (%d x %d pixels at %lld, %lld): ",
           (int)chunk->idx, (int)chunk->width, (int)chunk->height, (long long)x0, (long long)y0);
  exr_result_t rv = *started ? exr_decoding_update(rd->exr, 0, chunk, dec)
                             : exr_decoding_initialize(rd->exr, 0, chunk, dec);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  if (dec->channel_count != rd->channels->num_channels) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_INTERNAL, "OpenEXR decodes %d of %d channels",
                   (int)dec->channel_count, rd->channels->num_channels);
  }
  const hetinv_image_t *img = rd->image;
  for (int k = 0; k < dec->channel_count; ++k) {
    exr_coding_channel_info_t *ch = &dec->channels[k];
    float *origin = img->data + (size_t)rd->file_to_image[k] * img->pixel_count +
                    (size_t)y0 * (size_t)img->width + (size_t)x0;
    ch->decode_to_ptr = (uint8_t *)origin;
    ch->user_pixel_stride = (int32_t)sizeof(float);
    ch->user_line_stride = (int32_t)sizeof(float) * img->width;
    ch->user_data_type = EXR_PIXEL_FLOAT;
    ch->user_bytes_per_element = (int16_t)sizeof(float);
  }
  if (!*started) {
    rv = exr_decoding_choose_default_routines(rd->exr, 0, dec);
    if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
    /* NULL when OpenEXR reads uncompressed float rows straight into ours */
    if (dec->unpack_and_convert_fn != NULL) dec->unpack_and_convert_fn = unpack_to_float;
    if (dec->decompress_fn != NULL) {
      rd->decompress = dec->decompress_fn;
      dec->decompress_fn = decompress;
      dec->decoding_user_data = rd;
    }
    *started = true;
  }
  rv = exr_decoding_run(rd->exr, 0, dec);
  /* OpenEXR's decompressors also report corrupt streams as out of memory;
   * buffers for a chunk under 256 MiB cannot really exhaust it. */
  if (rv == EXR_ERR_OUT_OF_MEMORY && chunk->unpacked_size < ((uint64_t)1 << 28)) {
    rv = EXR_ERR_CORRUPT_CHUNK;
  }
  return rv == EXR_ERR_SUCCESS ? HETINV_SUCCESS : fail_exr(rd, rv);
}

static hetinv_result_t read_scanlines(exr_reader_t *rd, exr_decode_pipeline_t *dec,
                                      bool *started) {
  int32_t rows = 0;
  exr_result_t rv = exr_get_scanlines_per_chunk(rd->exr, 0, &rows);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  if (rows <= 0) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE, "'%s' has %d rows per chunk",
                   rd->path, (int)rows);
  }
  hetinv_result_t r = HETINV_SUCCESS;
  for (int64_t y = rd->window.min.y; y <= rd->window.max.y && r == HETINV_SUCCESS; y += rows) {
    exr_chunk_info_t chunk;
    snprintf(rd->where, sizeof rd->where, "the chunk of row %lld: ", (long long)y);
    rv = exr_read_scanline_chunk_info(rd->exr, 0, (int)y, &chunk);
    if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
    int64_t x0 = chunk.width == rd->width ? 0 : -1; /* -1: rejected by decode_chunk */
    r = decode_chunk(rd, dec, started, &chunk, x0, (int64_t)chunk.start_y - rd->window.min.y);
  }
  return r;
}

/* Reads level (0, 0), the full-resolution one, of a tiled image. */
static hetinv_result_t read_tiles(exr_reader_t *rd, exr_decode_pipeline_t *dec, bool *started) {
  int32_t tile_w = 0, tile_h = 0, level_w = 0, level_h = 0;
  exr_result_t rv = exr_get_tile_sizes(rd->exr, 0, 0, 0, &tile_w, &tile_h);
  if (rv == EXR_ERR_SUCCESS) rv = exr_get_level_sizes(rd->exr, 0, 0, 0, &level_w, &level_h);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
  if (tile_w <= 0 || tile_h <= 0 || level_w != rd->width || level_h != rd->height) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_CORRUPT_FILE,
                   "'%s' has %d x %d tiles and a %d x %d first level for a %d x %d data window",
                   rd->path, (int)tile_w, (int)tile_h, (int)level_w, (int)level_h, (int)rd->width,
                   (int)rd->height);
  }
  hetinv_result_t r = HETINV_SUCCESS;
  for (int64_t ty = 0; ty * tile_h < rd->height && r == HETINV_SUCCESS; ++ty) {
    for (int64_t tx = 0; tx * tile_w < rd->width && r == HETINV_SUCCESS; ++tx) {
      exr_chunk_info_t chunk;
      snprintf(rd->where, sizeof rd->where, "tile (%lld, %lld): ", (long long)tx, (long long)ty);
      rv = exr_read_tile_chunk_info(rd->exr, 0, (int)tx, (int)ty, 0, 0, &chunk);
      if (rv != EXR_ERR_SUCCESS) return fail_exr(rd, rv);
      r = decode_chunk(rd, dec, started, &chunk, tx * tile_w, ty * tile_h);
    }
  }
  return r;
}

static hetinv_result_t read_pixels(exr_reader_t *rd) {
  exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
  bool started = false;
  hetinv_result_t r = rd->storage == EXR_STORAGE_TILED ? read_tiles(rd, &dec, &started)
                                                       : read_scanlines(rd, &dec, &started);
  exr_decoding_destroy(rd->exr, &dec);
  rd->where[0] = '\0';
  return r;
}

HETINV_API hetinv_result_t hetinv_image_read_exr(hetinv_context_t *ctx, const char *path,
                                                 hetinv_image_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, path);
  exr_reader_t rd = {.ctx = ctx, .path = path, .fd = -1};
  hv_exr_clear_error();
  hetinv_result_t r = open_file(&rd);
  if (r == HETINV_SUCCESS) {
    hv_exr_clear_error(); /* messages of header attributes OpenEXR chose to skip */
    r = check_header(&rd);
  }
  if (r == HETINV_SUCCESS) {
    r = hv_image_alloc(ctx, rd.width, rd.height, rd.channels->num_channels, &rd.image);
  }
  if (r == HETINV_SUCCESS) r = order_channels(&rd);
  if (r == HETINV_SUCCESS) r = load_attributes(&rd);
  if (r == HETINV_SUCCESS) r = read_pixels(&rd);
  exr_finish(&rd.exr);
  if (rd.fd >= 0) close(rd.fd);
  hv_free(ctx, rd.file_to_image);
  if (r != HETINV_SUCCESS) {
    hetinv_image_destroy(&rd.image);
    return r;
  }
  *out = rd.image;
  return HETINV_SUCCESS;
}
