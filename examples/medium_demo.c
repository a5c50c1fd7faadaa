/* hetinv-medium-demo: builds a heterogeneous medium like the volumes of the
 * paper's Fig. 4 (each parameter a mixture of two Gaussian blobs on a 25 × 25
 * cross-section of a 10 mm cube), writes each parameter as a Mitsuba .vol
 * file, reads them back, and writes the cross-section as a 3-channel OpenEXR
 * image plus one PNG preview per parameter.
 *
 *   usage: hetinv-medium-demo [output-folder]      (default: out/demo)
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <hetinv/hetinv.h>

#include "outdir.h"

enum { N = 25 };

/* Reports a failed call with the library's message and leaves main. */
#define CHECK(call) \
  do { \
    hetinv_result_t r_ = (call); \
    if (r_ != HETINV_SUCCESS) { \
      fprintf(stderr, "hetinv-medium-demo: %s: %s\n", hetinv_result_name(r_), \
              hetinv_context_last_error_message(NULL)); \
      goto done; \
    } \
  } while (0)

/* Value at (x, y) in [0,1]² of lo + (hi-lo) · (mixture of two Gaussian blobs),
 * normalised so the mixture peaks at most at 1. */
static double blobs(double x, double y, const double blob[2][3], double lo, double hi) {
  double v = 0.0;
  for (int b = 0; b < 2; ++b) {
    double dx = x - blob[b][0], dy = y - blob[b][1], s = blob[b][2];
    v += exp(-(dx * dx + dy * dy) / (2.0 * s * s));
  }
  v = v > 1.0 ? 1.0 : v;
  return lo + (hi - lo) * v;
}

int main(int argc, char **argv) {
  const char *dir = argc > 1 ? argv[1] : "out/demo";
  if (argc == 2 && (strcmp(argv[1], "-h") == 0 || strcmp(argv[1], "--help") == 0)) {
    printf("hetinv-medium-demo: a Fig. 4-like medium written as .vol files, read back, and its section as EXR and PNG\n"
           "usage: %s [output-folder]   (default out/demo)\n", argv[0]);
    return 0;
  }
  if (argc > 2 || (argc == 2 && argv[1][0] == '-')) {
    fprintf(stderr, "usage: %s [output-folder]\n", argv[0]);
    return 2;
  }
  /* A folder we can write, locked for this run (released by the kernel
   * however the process ends), cleared of temporaries a killed run left. */
  outdir_t out;
  if (outdir_open(&out, "hetinv-medium-demo", dir) != 0) return 1;

  int status = 1;
  hetinv_context_t *ctx = NULL;
  hetinv_medium_t *truth = NULL, *loaded = NULL;
  hetinv_image_t *image = NULL;
  CHECK(hetinv_context_create(NULL, &ctx));

  /* A 10 mm cube; nz = 1 makes the 25 × 25 grid a cross-section constant along z. */
  const double lo[3] = {0, 0, 0}, hi[3] = {10, 10, 10};
  const int32_t dims[3] = {N, N, 1};
  CHECK(hetinv_medium_create(ctx, lo, hi, dims, &truth));
  CHECK(hetinv_medium_set_ior(truth, 1.3, 1.0));
  /* Blob centres (x, y) and widths, one pair per parameter. */
  static const double blob[3][2][3] = {
      {{0.3, 0.35, 0.15}, {0.7, 0.7, 0.2}},
      {{0.65, 0.3, 0.2}, {0.25, 0.75, 0.12}},
      {{0.5, 0.5, 0.25}, {0.15, 0.2, 0.1}},
  };
  /* The paper's box constraints: σa, σs in [1, 10] /mm, g in [0, 0.6]. */
  static const double range[3][2] = {{1, 10}, {1, 10}, {0, 0.6}};
  double values[N * N];
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    for (int y = 0; y < N; ++y) {
      for (int x = 0; x < N; ++x) {
        values[x + N * y] = blobs((x + 0.5) / N, (y + 0.5) / N, blob[p], range[p][0], range[p][1]);
      }
    }
    CHECK(hetinv_medium_set_grid(truth, p, values, N * N));
  }
  CHECK(hetinv_medium_commit(truth));

  /* Each parameter as a .vol file, read back into a second medium. */
  char path[4200];
  CHECK(hetinv_medium_create(ctx, lo, hi, dims, &loaded));
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    snprintf(path, sizeof path, "%s/%s.vol", dir, hetinv_param_name(p));
    CHECK(hetinv_medium_write_vol(truth, p, path));
    CHECK(hetinv_medium_read_vol(loaded, p, path));
    printf("wrote %s\n", path);
  }
  double worst = 0.0;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    const double *a = hetinv_medium_grid(truth, p), *b = hetinv_medium_grid(loaded, p);
    for (int i = 0; i < N * N; ++i) worst = fmax(worst, fabs(a[i] - b[i]) / fmax(fabs(a[i]), 1e-12));
  }
  printf(".vol round trip: largest relative difference %.2e (float32 storage)\n", worst);

  /* The cross-section as one EXR with a channel per parameter, and PNG previews. */
  CHECK(hetinv_image_create(ctx, N, N, HETINV_PARAM_COUNT, &image));
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    CHECK(hetinv_image_set_channel_name(image, p, hetinv_param_name(p)));
    float *px = hetinv_image_channel_data(image, p);
    const double *v = hetinv_medium_grid(truth, p);
    for (int y = 0; y < N; ++y) {
      for (int x = 0; x < N; ++x) px[(N - 1 - y) * N + x] = (float)v[x + N * y]; /* y up */
    }
  }
  CHECK(hetinv_image_set_attribute_string(image, "hetinv:content", "medium cross-section z=0"));
  CHECK(hetinv_image_set_attribute_double(image, "hetinv:voxelSize", 10.0 / N));
  CHECK(hetinv_image_set_attribute_string(image, "hetinv:lengthUnit", "mm"));
  snprintf(path, sizeof path, "%s/cross_section.exr", dir);
  CHECK(hetinv_image_write_exr(image, path));
  printf("wrote %s\n", path);
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    snprintf(path, sizeof path, "%s/%s.png", dir, hetinv_param_name(p));
    CHECK(hetinv_image_write_png(image, p, path, range[p][0], range[p][1],
                                 HETINV_COLORMAP_VIRIDIS));
    printf("wrote %s  (%s from %g to %g)\n", path, hetinv_param_name(p), range[p][0], range[p][1]);
  }
  status = worst < 1e-6 ? 0 : 1;
  if (status != 0) fprintf(stderr, "hetinv-medium-demo: .vol round trip lost precision\n");

done:
  hetinv_image_destroy(&image);
  hetinv_medium_destroy(&loaded);
  hetinv_medium_destroy(&truth);
  hetinv_context_destroy(&ctx);
  if (outdir_finish_stdout("hetinv-medium-demo") != 0) status = 1;
  outdir_close(&out);
  return status;
}
