/* PNG previews: colour maps, ranges, non-finite values, failures. */
#include <math.h>
#include <png.h>
#include <stdlib.h>

#include "test_support.h"

static int setup(void **state) {
  ht_tmpdir_create("png");
  return ht_context_setup(state);
}

static int teardown(void **state) {
  ht_tmpdir_remove();
  return ht_context_teardown(state);
}

/* An image of one row holding @p values, in channel 1 of 2. */
static hetinv_image_t *row_image(hetinv_context_t *ctx, const float *values, int32_t n) {
  hetinv_image_t *img = NULL;
  assert_ok(hetinv_image_create(ctx, n, 1, 2, &img));
  memcpy(hetinv_image_channel_data(img, 1), values, (size_t)n * sizeof(float));
  return img;
}

/* Decoded with libpng. */
typedef struct decoded {
  png_uint_32 width, height;
  png_uint_32 format; /* as stored in the file */
  unsigned char *rgb;
} decoded_t;

static decoded_t decode(const char *path) {
  png_image image;
  memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  assert_true(png_image_begin_read_from_file(&image, path));
  decoded_t d = {image.width, image.height, image.format, NULL};
  image.format = PNG_FORMAT_RGB;
  d.rgb = malloc(PNG_IMAGE_SIZE(image));
  assert_non_null(d.rgb);
  assert_true(png_image_finish_read(&image, NULL, d.rgb, 0, NULL));
  return d;
}

static void assert_pixel(const decoded_t *d, png_uint_32 x, png_uint_32 y, int r, int g, int b) {
  const unsigned char *p = d->rgb + 3 * (y * d->width + x);
  if (p[0] != r || p[1] != g || p[2] != b) {
    print_error("pixel (%u, %u) is (%d, %d, %d), expected (%d, %d, %d)\n", (unsigned)x, (unsigned)y,
                p[0], p[1], p[2], r, g, b);
    fail();
  }
}

static void gray_maps_the_range_linearly(void **state) {
  const float v[] = {0.0f, 0.5f, 1.0f, 2.0f, -1.0f, NAN, INFINITY, 0.25f};
  hetinv_image_t *img = row_image(*state, v, 8);
  assert_ok(hetinv_image_write_png(img, 1, ht_path("gray.png"), 0.0, 1.0, HETINV_COLORMAP_GRAY));
  assert_int_equal(ht_tmpdir_entry_count(), 1); /* no temporary file left */
  decoded_t d = decode(ht_path("gray.png"));
  assert_int_equal(d.width, 8);
  assert_int_equal(d.height, 1);
  assert_int_equal(d.format, PNG_FORMAT_RGB); /* 8-bit RGB, no alpha */
  assert_pixel(&d, 0, 0, 0, 0, 0);
  assert_pixel(&d, 1, 0, 128, 128, 128);
  assert_pixel(&d, 2, 0, 255, 255, 255);
  assert_pixel(&d, 3, 0, 255, 255, 255); /* clamped */
  assert_pixel(&d, 4, 0, 0, 0, 0);       /* clamped */
  assert_pixel(&d, 5, 0, 0, 0, 0);       /* NaN: black */
  assert_pixel(&d, 6, 0, 0, 0, 0);       /* inf: black */
  assert_pixel(&d, 7, 0, 64, 64, 64);
  free(d.rgb);
  hetinv_image_destroy(&img);
}

static void viridis_runs_from_dark_blue_to_yellow(void **state) {
  const float v[] = {-5.0f, 5.0f, 0.0f, NAN, -INFINITY, 1.25f};
  hetinv_image_t *img = row_image(*state, v, 6);
  assert_ok(hetinv_image_write_png(img, 1, ht_path("v.png"), -5.0, 5.0, HETINV_COLORMAP_VIRIDIS));
  decoded_t d = decode(ht_path("v.png"));
  assert_pixel(&d, 0, 0, 68, 1, 84);     /* low end */
  assert_pixel(&d, 1, 0, 253, 231, 37);  /* high end */
  assert_pixel(&d, 2, 0, 33, 144, 140);  /* middle */
  assert_pixel(&d, 3, 0, 255, 0, 255);   /* NaN: magenta */
  assert_pixel(&d, 4, 0, 255, 0, 255);   /* -inf: magenta */
  assert_pixel(&d, 5, 0, 40, 174, 128);  /* t = 0.625 = 10/16, a control point */
  free(d.rgb);
  hetinv_image_destroy(&img);
}

static void equal_bounds_use_the_finite_range(void **state) {
  const float v[] = {10.0f, 20.0f, 15.0f, NAN, -INFINITY};
  hetinv_image_t *img = row_image(*state, v, 5);
  assert_ok(hetinv_image_write_png(img, 1, ht_path("auto.png"), 3.0, 3.0, HETINV_COLORMAP_GRAY));
  decoded_t d = decode(ht_path("auto.png"));
  assert_pixel(&d, 0, 0, 0, 0, 0);
  assert_pixel(&d, 1, 0, 255, 255, 255);
  assert_pixel(&d, 2, 0, 128, 128, 128);
  free(d.rgb);
  /* A constant channel draws at the low end. */
  assert_ok(hetinv_image_write_png(img, 0, ht_path("flat.png"), 0.0, 0.0, HETINV_COLORMAP_VIRIDIS));
  d = decode(ht_path("flat.png"));
  for (png_uint_32 x = 0; x < 5; ++x) assert_pixel(&d, x, 0, 68, 1, 84);
  free(d.rgb);
  hetinv_image_destroy(&img);
}

static void rows_run_top_to_bottom(void **state) {
  hetinv_image_t *img = NULL;
  assert_ok(hetinv_image_create(*state, 3, 4, 1, &img));
  float *p = hetinv_image_channel_data(img, 0);
  p[3 * 3 + 2] = 1.0f; /* pixel (2, 3): bottom right */
  assert_ok(hetinv_image_write_png(img, 0, ht_path("rows.png"), 0.0, 1.0, HETINV_COLORMAP_GRAY));
  decoded_t d = decode(ht_path("rows.png"));
  assert_int_equal(d.width, 3);
  assert_int_equal(d.height, 4);
  assert_pixel(&d, 2, 3, 255, 255, 255);
  assert_pixel(&d, 2, 0, 0, 0, 0);
  free(d.rgb);
  /* writing again replaces the file */
  p[0] = 1.0f;
  assert_ok(hetinv_image_write_png(img, 0, ht_path("rows.png"), 0.0, 1.0, HETINV_COLORMAP_GRAY));
  d = decode(ht_path("rows.png"));
  assert_pixel(&d, 0, 0, 255, 255, 255);
  free(d.rgb);
  assert_int_equal(ht_tmpdir_entry_count(), 1);
  hetinv_image_destroy(&img);
}

static void bad_arguments_are_rejected(void **state) {
  const float v[] = {1.0f, 2.0f};
  hetinv_image_t *img = row_image(*state, v, 2);
  const char *path = ht_path("bad.png");
  assert_result(HETINV_ERROR_OUT_OF_RANGE,
                hetinv_image_write_png(img, 2, path, 0, 1, HETINV_COLORMAP_GRAY));
  assert_message_contains("hetinv_image_write_png: channel is 2; the image has 2 channels");
  assert_result(HETINV_ERROR_OUT_OF_RANGE,
                hetinv_image_write_png(img, -1, path, 0, 1, HETINV_COLORMAP_GRAY));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_write_png(img, 0, path, 0, 1, 2));
  assert_message_contains("colormap is 2");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_image_write_png(img, 0, path, 0, 1, -1));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_image_write_png(img, 0, path, 2, 1, HETINV_COLORMAP_GRAY));
  assert_message_contains("the range is [2, 1]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_image_write_png(img, 0, path, (double)NAN, 1, HETINV_COLORMAP_GRAY));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_image_write_png(img, 0, path, 0, HUGE_VAL, HETINV_COLORMAP_VIRIDIS));
  assert_message_contains("[0, inf]");
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_image_write_png(img, 0, NULL, 0, 1, HETINV_COLORMAP_GRAY));
  assert_message_contains("'path' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_image_write_png(NULL, 0, path, 0, 1, HETINV_COLORMAP_GRAY));
  assert_int_equal(ht_tmpdir_entry_count(), 0);
  hetinv_image_destroy(&img);
}

static void unwritable_destination_is_an_io_error(void **state) {
  const float v[] = {1.0f};
  hetinv_image_t *img = row_image(*state, v, 1);
  assert_result(HETINV_ERROR_IO, hetinv_image_write_png(img, 1, ht_path("missing/p.png"), 0, 1,
                                                        HETINV_COLORMAP_GRAY));
  assert_message_contains("missing/p.png");
  ht_write_file(ht_path("file"), "x", 1); /* not a directory */
  assert_result(HETINV_ERROR_IO,
                hetinv_image_write_png(img, 1, ht_path("file/p.png"), 0, 1, HETINV_COLORMAP_GRAY));
  assert_int_equal(ht_tmpdir_entry_count(), 1);
  hetinv_image_destroy(&img);
}

#define PNG_TEST(name) cmocka_unit_test_setup_teardown(name, setup, teardown)

int main(void) {
  const struct CMUnitTest tests[] = {
      PNG_TEST(gray_maps_the_range_linearly),
      PNG_TEST(viridis_runs_from_dark_blue_to_yellow),
      PNG_TEST(equal_bounds_use_the_finite_range),
      PNG_TEST(rows_run_top_to_bottom),
      PNG_TEST(bad_arguments_are_rejected),
      PNG_TEST(unwritable_destination_is_an_io_error),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
