#include <errno.h>
#include <math.h>
#include <png.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "io/image_internal.h"

/* Viridis (matplotlib's, by van der Walt and Smith) sampled at t = k/16;
 * interpolating linearly between these stays within 6/255 of the full map. */
static const uint8_t VIRIDIS[17][3] = {
    {68, 1, 84},    {72, 24, 106},  {71, 45, 123},  {66, 64, 134},  {59, 82, 139},
    {51, 99, 141},  {44, 114, 142}, {38, 129, 142}, {33, 144, 140}, {31, 159, 136},
    {40, 174, 128}, {62, 188, 116}, {93, 201, 99},  {130, 211, 76}, {171, 220, 50},
    {213, 226, 26}, {253, 231, 37}};

/* Colour of a value at @p t in [0, 1] of the range, or of a non-finite value. */
static void shade(int32_t colormap, bool finite, double t, uint8_t rgb[3]) {
  if (colormap == HETINV_COLORMAP_GRAY) {
    uint8_t v = finite ? (uint8_t)lround(t * 255.0) : 0;
    rgb[0] = rgb[1] = rgb[2] = v;
    return;
  }
  if (!finite) { /* magenta: absent from viridis, so it stands out */
    rgb[0] = 255, rgb[1] = 0, rgb[2] = 255;
    return;
  }
  double x = t * 16.0;
  int k = x >= 16.0 ? 15 : (int)x;
  double f = x - k;
  for (int i = 0; i < 3; ++i) {
    rgb[i] = (uint8_t)lround(VIRIDIS[k][i] + f * (VIRIDIS[k + 1][i] - VIRIDIS[k][i]));
  }
}

typedef struct png_job {
  const float *values; /* the channel */
  int32_t width, height, colormap;
  double lo, hi;
  uint8_t *row; /* width·3 bytes */
  const hetinv_context_t *ctx;
  bool out_of_memory; /* our allocator refused libpng a block: libpng's error is ours */
  char message[256];
} png_job_t;

static void render_row(const png_job_t *job, int32_t y) {
  const float *v = job->values + (size_t)y * (size_t)job->width;
  /* halves keep hi - lo finite for any finite lo, hi */
  double span = 0.5 * job->hi - 0.5 * job->lo;
  for (int32_t x = 0; x < job->width; ++x) {
    bool finite = isfinite(v[x]);
    double t = 0.0; /* a zero span (constant image) draws everything at the low end */
    if (finite && span > 0.0) t = (0.5 * (double)v[x] - 0.5 * job->lo) / span;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    shade(job->colormap, finite, t, job->row + 3 * (size_t)x);
  }
}

static void on_png_error(png_structp png, png_const_charp message) {
  int err = errno; /* libpng's "Write Error" follows a failed fwrite: say why */
  png_job_t *job = png_get_error_ptr(png);
  if (strcmp(message, "Write Error") == 0 && err != 0) {
    snprintf(job->message, sizeof job->message, "%s", strerror(err));
  } else {
    snprintf(job->message, sizeof job->message, "%s", message);
  }
  png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp message) {
  (void)png, (void)message; /* libpng would print it; nothing we write warrants one */
}

/* libpng allocates through the context's allocator. A refusal is remembered,
 * so that the error libpng raises for it is reported as
 * HETINV_ERROR_OUT_OF_MEMORY, not as an I/O error. */
static png_voidp png_alloc(png_structp png, png_alloc_size_t size) {
  png_job_t *job = png_get_mem_ptr(png);
  void *p = hv_alloc(job->ctx, size);
  if (p == NULL) job->out_of_memory = true;
  return p;
}
static void png_release(png_structp png, png_voidp ptr) {
  png_job_t *job = png_get_mem_ptr(png);
  hv_free(job->ctx, ptr);
}

/* Encodes the image; false (with job->message) if libpng failed. */
static bool encode(png_structp png, png_infop info, FILE *fp, png_job_t *job) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_init_io(png, fp);
  png_set_user_limits(png, PNG_UINT_31_MAX, PNG_UINT_31_MAX); /* default caps at 1e6 */
  png_set_IHDR(png, info, (png_uint_32)job->width, (png_uint_32)job->height, 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int32_t y = 0; y < job->height; ++y) {
    render_row(job, y);
    png_write_row(png, job->row);
  }
  png_write_end(png, NULL);
  return true;
}

/* Finite minimum and maximum of the channel; [0, 0] if none is finite. */
static void finite_range(const float *v, size_t n, double *lo, double *hi) {
  bool any = false;
  *lo = *hi = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double x = (double)v[i];
    if (!isfinite(x)) continue;
    if (!any || x < *lo) *lo = x;
    if (!any || x > *hi) *hi = x;
    any = true;
  }
}

HETINV_API hetinv_result_t hetinv_image_write_png(const hetinv_image_t *image, int32_t channel,
                                                  const char *path, double lo, double hi,
                                                  int32_t colormap) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, image);
  const hetinv_context_t *ctx = image->ctx;
  HV_CHECK_NULL(ctx, path);
  if (channel < 0 || channel >= image->channel_count) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "channel is %d; the image has %d channels (0 to %d)", (int)channel,
                   (int)image->channel_count, (int)image->channel_count - 1);
  }
  if (colormap != HETINV_COLORMAP_GRAY && colormap != HETINV_COLORMAP_VIRIDIS) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_RANGE,
                   "colormap is %d; it must be HETINV_COLORMAP_GRAY (0) or _VIRIDIS (1)",
                   (int)colormap);
  }
  if (!isfinite(lo) || !isfinite(hi) || lo > hi) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the range is [%g, %g]; it must be finite with lo <= hi", lo, hi);
  }
  png_job_t job = {.values = image->data + (size_t)channel * image->pixel_count,
                   .width = image->width,
                   .height = image->height,
                   .colormap = colormap,
                   .lo = lo,
                   .hi = hi,
                   .ctx = ctx};
  if (lo == hi) finite_range(job.values, image->pixel_count, &job.lo, &job.hi);
  job.row = hv_calloc(ctx, (size_t)image->width, 3);
  if (job.row == NULL) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a row of %d pixels",
                   (int)image->width);
  }
  hv_atomic_file_t file;
  hetinv_result_t r = hv_atomic_open(ctx, path, 1, &file);
  if (r != HETINV_SUCCESS) {
    hv_free(ctx, job.row);
    return r;
  }
  png_structp png = png_create_write_struct_2(PNG_LIBPNG_VER_STRING, &job, on_png_error,
                                              on_png_warning, &job, png_alloc, png_release);
  png_infop info = png != NULL ? png_create_info_struct(png) : NULL;
  if (info == NULL) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot create the PNG writer for '%s'", path);
  } else if (!encode(png, info, file.fp, &job)) {
    r = job.out_of_memory
            ? HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot write '%s': libpng: %s", path, job.message)
            : HV_FAIL(ctx, HETINV_ERROR_IO, "cannot write '%s': %s", path, job.message);
  }
  png_destroy_write_struct(png != NULL ? &png : NULL, info != NULL ? &info : NULL);
  hv_free(ctx, job.row);
  if (r != HETINV_SUCCESS) {
    hv_atomic_abort(&file);
    return r;
  }
  return hv_atomic_commit(&file);
}
