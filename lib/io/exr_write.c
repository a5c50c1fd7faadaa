#include <fcntl.h>
#include <stdint.h>
#include <string.h>
#include <unistd.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "io/image_internal.h"

enum { ZIP_ROWS_PER_CHUNK = 16 };

/* One write in progress. */
typedef struct exr_job {
  const hetinv_image_t *image;
  const char *path;
  exr_context_t exr;
  int part;
  int32_t *file_to_image; /* channel k of the file is image channel file_to_image[k] */
  exr_result_t (*compress)(exr_encode_pipeline_t *); /* OpenEXR's own */
} exr_job_t;

/* Failure of an OpenEXR call. */
static hetinv_result_t fail_exr(const exr_job_t *job, const char *call, exr_result_t rv) {
  hetinv_result_t code = HETINV_ERROR_INTERNAL; /* our arguments are valid: anything else is a bug */
  if (rv == EXR_ERR_OUT_OF_MEMORY) code = HETINV_ERROR_OUT_OF_MEMORY;
  if (rv == EXR_ERR_FILE_ACCESS || rv == EXR_ERR_WRITE_IO) code = HETINV_ERROR_IO;
  return HV_FAIL(job->image->ctx, code, "cannot write '%s': %s: %s (%s)",
                 job->path, call, hv_exr_error_message(rv), exr_get_error_code_as_string(rv));
}

/* Declares the part: size, ZIP, float channels, attributes. */
static hetinv_result_t define_header(exr_job_t *job) {
  const hetinv_image_t *img = job->image;
  exr_context_t exr = job->exr;
  exr_result_t rv;
  bool long_names = false;
  for (int32_t c = 0; c < img->channel_count; ++c) long_names |= strlen(img->channel_names[c]) > 31;
  for (int32_t i = 0; i < img->attribute_count; ++i) {
    long_names |= strlen(img->attributes[i].name) > 31;
  }
  /* Names over 31 bytes need the long-name flag (readers from OpenEXR 1.7 on). */
  if (long_names && (rv = exr_set_longname_support(exr, 1)) != EXR_ERR_SUCCESS) {
    return fail_exr(job, "exr_set_longname_support", rv);
  }
  if ((rv = exr_add_part(exr, NULL, EXR_STORAGE_SCANLINE, &job->part)) != EXR_ERR_SUCCESS) {
    return fail_exr(job, "exr_add_part", rv);
  }
  rv = exr_initialize_required_attr_simple(exr, job->part, img->width, img->height,
                                           EXR_COMPRESSION_ZIP);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(job, "exr_initialize_required_attr_simple", rv);
  for (int32_t c = 0; c < img->channel_count; ++c) {
    rv = exr_add_channel(exr, job->part, img->channel_names[c], EXR_PIXEL_FLOAT,
                         EXR_PERCEPTUALLY_LINEAR, 1, 1);
    if (rv != EXR_ERR_SUCCESS) return fail_exr(job, "exr_add_channel", rv);
  }
  for (int32_t i = 0; i < img->attribute_count; ++i) {
    const hv_image_attribute_t *a = &img->attributes[i];
    if (a->type == HETINV_ATTRIBUTE_STRING) {
      rv = exr_attr_set_string(exr, job->part, a->name, a->string);
    } else if (a->type == HETINV_ATTRIBUTE_DOUBLE) {
      rv = exr_attr_set_double(exr, job->part, a->name, a->real);
    } else {
      rv = exr_attr_set_int(exr, job->part, a->name, a->integer);
    }
    if (rv != EXR_ERR_SUCCESS) return fail_exr(job, "exr_attr_set", rv);
  }
  return HETINV_SUCCESS;
}

/* Maps the file's (sorted) channels to the image's; records the image order
 * in HV_EXR_CHANNEL_ORDER when it differs. */
static hetinv_result_t map_channels(exr_job_t *job) {
  const hetinv_image_t *img = job->image;
  const exr_attr_chlist_t *list = NULL;
  exr_result_t rv = exr_get_channels(job->exr, job->part, &list);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(job, "exr_get_channels", rv);
  if (list->num_channels != img->channel_count) {
    return HV_FAIL(img->ctx, HETINV_ERROR_INTERNAL,
                   "OpenEXR lists %d channels for %d added", list->num_channels,
                   (int)img->channel_count);
  }
  job->file_to_image = hv_calloc(img->ctx, (size_t)img->channel_count, sizeof(int32_t));
  hv_name_index_t *index =
      hv_name_index_build(img->ctx, (const char *const *)img->channel_names, img->channel_count);
  if (job->file_to_image == NULL || index == NULL) {
    hv_free(img->ctx, index);
    return HV_FAIL(img->ctx, HETINV_ERROR_OUT_OF_MEMORY,
                   "cannot allocate a table of %d channels", (int)img->channel_count);
  }
  bool reordered = false;
  for (int32_t k = 0; k < img->channel_count; ++k) {
    job->file_to_image[k] = hv_name_index_find(index, img->channel_count, list->entries[k].name.str);
    reordered |= job->file_to_image[k] != k;
  }
  hv_free(img->ctx, index);
  if (reordered) {
    /* the API wants char** though it only reads the strings */
    rv = exr_attr_set_string_vector(job->exr, job->part, HV_EXR_CHANNEL_ORDER,
                                    img->channel_count, (const char **)(void *)img->channel_names);
    if (rv != EXR_ERR_SUCCESS) return fail_exr(job, "exr_attr_set_string_vector", rv);
  }
  return HETINV_SUCCESS;
}

/* A chunk whose packed size is not below its raw size is raw data to every
 * reader (the OpenEXR format; the C++ library writes such chunks raw).
 * OpenEXR 3.1's core keeps a ZIP chunk that comes out exactly as long as the
 * raw data, which any reader then takes for pixels: store the raw bytes. */
static exr_result_t compress_or_store(exr_encode_pipeline_t *enc) {
  exr_result_t rv = ((const exr_job_t *)enc->encoding_user_data)->compress(enc);
  if (rv != EXR_ERR_SUCCESS || enc->compressed_bytes < enc->packed_bytes) return rv;
  if (enc->compressed_buffer == NULL || enc->compressed_alloc_size < enc->packed_bytes) {
    return EXR_ERR_INVALID_ARGUMENT; /* OpenEXR's buffer cannot hold the raw chunk: a bug */
  }
  memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
  enc->compressed_bytes = enc->packed_bytes;
  return EXR_ERR_SUCCESS;
}

/* Encodes and writes every chunk, top to bottom. */
static hetinv_result_t write_chunks(exr_job_t *job) {
  const hetinv_image_t *img = job->image;
  int32_t rows = 0;
  exr_result_t rv = exr_get_scanlines_per_chunk(job->exr, job->part, &rows);
  if (rv != EXR_ERR_SUCCESS) return fail_exr(job, "exr_get_scanlines_per_chunk", rv);
  exr_encode_pipeline_t encoder = EXR_ENCODE_PIPELINE_INITIALIZER;
  bool started = false;
  const char *call = NULL;
  for (int32_t y = 0; y < img->height && rv == EXR_ERR_SUCCESS; y += rows) {
    exr_chunk_info_t chunk;
    call = "exr_write_scanline_chunk_info";
    rv = exr_write_scanline_chunk_info(job->exr, job->part, y, &chunk);
    if (rv == EXR_ERR_SUCCESS) {
      call = started ? "exr_encoding_update" : "exr_encoding_initialize";
      rv = started ? exr_encoding_update(job->exr, job->part, &chunk, &encoder)
                   : exr_encoding_initialize(job->exr, job->part, &chunk, &encoder);
    }
    for (int32_t k = 0; rv == EXR_ERR_SUCCESS && k < encoder.channel_count; ++k) {
      exr_coding_channel_info_t *ch = &encoder.channels[k];
      const float *rows_start = img->data + (size_t)job->file_to_image[k] * img->pixel_count +
                                (size_t)y * (size_t)img->width;
      ch->encode_from_ptr = (const uint8_t *)rows_start;
      ch->user_pixel_stride = (int32_t)sizeof(float);
      ch->user_line_stride = (int32_t)sizeof(float) * img->width;
      ch->user_data_type = EXR_PIXEL_FLOAT;
      ch->user_bytes_per_element = (int16_t)sizeof(float);
    }
    if (rv == EXR_ERR_SUCCESS && !started) {
      call = "exr_encoding_choose_default_routines";
      rv = exr_encoding_choose_default_routines(job->exr, job->part, &encoder);
      started = rv == EXR_ERR_SUCCESS;
      if (started && encoder.compress_fn != NULL) {
        job->compress = encoder.compress_fn;
        encoder.compress_fn = compress_or_store;
        encoder.encoding_user_data = job;
      }
    }
    if (rv == EXR_ERR_SUCCESS) {
      call = "exr_encoding_run";
      rv = exr_encoding_run(job->exr, job->part, &encoder);
    }
  }
  if (started || encoder.channels != NULL) exr_encoding_destroy(job->exr, &encoder);
  return rv == EXR_ERR_SUCCESS ? HETINV_SUCCESS : fail_exr(job, call, rv);
}

/* Limits of the OpenEXR format and library that a valid image may exceed. */
static hetinv_result_t check_limits(const hetinv_image_t *img, const char *path) {
  if (img->channel_count > INT16_MAX) {
    return HV_FAIL(img->ctx, HETINV_ERROR_UNSUPPORTED,
                   "cannot write '%s': the image has %d channels; OpenEXR handles at most %d",
                   path, (int)img->channel_count, INT16_MAX);
  }
  /* A chunk's byte count is an int32 in the file (and strides are int32). */
  uint64_t chunk_bytes = (uint64_t)ZIP_ROWS_PER_CHUNK * (uint64_t)img->width *
                         (uint64_t)img->channel_count * sizeof(float);
  if (chunk_bytes > INT32_MAX) {
    return HV_FAIL(img->ctx, HETINV_ERROR_UNSUPPORTED,
                   "cannot write '%s': %d rows of %d pixels x %d channels exceed OpenEXR's 2 GiB "
                   "chunk limit",
                   path, ZIP_ROWS_PER_CHUNK, (int)img->width, (int)img->channel_count);
  }
  return HETINV_SUCCESS;
}

/* Flushes the finished temporary file to disk before it is renamed into place. */
static hetinv_result_t sync_file(const hetinv_image_t *img, const char *tmp_path, const char *path) {
  int fd = open(tmp_path, O_RDONLY);
  bool ok = fd >= 0 && fsync(fd) == 0;
  if (fd >= 0) close(fd);
  if (ok) return HETINV_SUCCESS;
  return HV_FAIL(img->ctx, HETINV_ERROR_IO,
                 "cannot flush the temporary file of '%s' to disk", path);
}

HETINV_API hetinv_result_t hetinv_image_write_exr(const hetinv_image_t *image, const char *path) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, image);
  HV_CHECK_NULL(image->ctx, path);
  hetinv_result_t r = check_limits(image, path);
  if (r != HETINV_SUCCESS) return r;
  hv_atomic_file_t file;
  r = hv_atomic_open(image->ctx, path, 0, &file);
  if (r != HETINV_SUCCESS) return r;

  exr_job_t job = {.image = image, .path = path};
  exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
  init.error_handler_fn = hv_exr_record_error;
  hv_exr_clear_error();
  exr_result_t rv = exr_start_write(&job.exr, file.tmp_path, EXR_WRITE_FILE_DIRECTLY, &init);
  if (rv != EXR_ERR_SUCCESS) r = fail_exr(&job, "exr_start_write", rv);
  if (r == HETINV_SUCCESS) r = define_header(&job);
  if (r == HETINV_SUCCESS) r = map_channels(&job);
  if (r == HETINV_SUCCESS && (rv = exr_write_header(job.exr)) != EXR_ERR_SUCCESS) {
    r = fail_exr(&job, "exr_write_header", rv);
  }
  if (r == HETINV_SUCCESS) r = write_chunks(&job);
  /* exr_finish writes the chunk offset table; on an unfinished write it
   * deletes the temporary file (hv_atomic_abort then finds nothing). */
  rv = exr_finish(&job.exr);
  if (r == HETINV_SUCCESS && rv != EXR_ERR_SUCCESS) r = fail_exr(&job, "exr_finish", rv);
  hv_free(image->ctx, job.file_to_image);
  if (r == HETINV_SUCCESS) r = sync_file(image, file.tmp_path, path);
  if (r != HETINV_SUCCESS) {
    hv_atomic_abort(&file);
    return r;
  }
  return hv_atomic_commit(&file);
}
