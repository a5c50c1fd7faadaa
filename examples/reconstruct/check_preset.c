/* hetinv-preset-check: test helper. A preset written with
 * `hetinv-reconstruct --write-scene` and rendered by hetinv-render must be
 * the simulated acquisition itself: the same rows in the same order, the
 * same layout, and (without camera noise) the same values and standard
 * errors, bit for bit after the same rounding to float. Reads the files
 * through the reconstruction scene the preset wrote (files mode) and the
 * simulated run's measurements.exr into the same set, and compares.
 *
 *   usage: hetinv-preset-check RECONSTRUCT_SCENE MEASUREMENTS_EXR
 *
 * Prints the rows and values compared; exit 0 when every value and
 * standard error is equal, 1 otherwise (naming the first that differs). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "recon.h"

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: hetinv-preset-check RECONSTRUCT_SCENE MEASUREMENTS_EXR\n");
    return 2;
  }
  hetinv_context_t *ctx = NULL;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return 1;
  recon_scene_t sc;
  recon_scene_default(&sc);
  recon_imaging_t im;
  memset(&im, 0, sizeof im);
  char msg[4096];
  int status = 1;
  double *files_v = NULL, *files_se = NULL;
  size_t n = 0;
  if (recon_scene_read(argv[1], &sc, msg, sizeof msg) < 0 || recon_files_load(ctx, &sc, &im, msg, sizeof msg) < 0) {
    fprintf(stderr, "hetinv-preset-check: %s\n", msg);
    goto done;
  }
  n = hetinv_measurements_value_count(im.set);
  files_v = malloc(n * sizeof *files_v);
  files_se = malloc(n * sizeof *files_se);
  if (files_v == NULL || files_se == NULL) goto done;
  memcpy(files_v, hetinv_measurements_values(im.set), n * sizeof *files_v);
  memcpy(files_se, hetinv_measurements_std_errors(im.set), n * sizeof *files_se);
  /* The simulated measurements into the same set: a layout check too. */
  if (recon_measurements_read(ctx, &im, argv[2], msg, sizeof msg) != HETINV_SUCCESS) {
    fprintf(stderr, "hetinv-preset-check: %s\n", msg);
    goto done;
  }
  const double *v = hetinv_measurements_values(im.set), *se = hetinv_measurements_std_errors(im.set);
  int32_t rows = hetinv_measurements_row_count(im.set);
  size_t lit = 0;
  status = 0;
  for (int32_t row = 0; row < rows && status == 0; ++row) {
    size_t off = 0;
    int32_t pixels = 0, bins = 0;
    hetinv_measurements_row_layout(im.set, row, &off, &pixels, &bins);
    for (size_t i = off; i < off + (size_t)pixels * (size_t)bins; ++i) {
      lit += v[i] > 0.0;
      if (files_v[i] != v[i] || files_se[i] != se[i]) {
        fprintf(stderr, "hetinv-preset-check: row %d value %zu: rendered %.9g +- %.9g, simulated %.9g +- %.9g\n",
                (int)row, i - off, files_v[i], files_se[i], v[i], se[i]);
        status = 1;
        break;
      }
    }
  }
  if (status == 0) printf("%d rows, %zu values (%zu lit): rendered preset = simulated acquisition, bit for bit\n",
                          (int)rows, n, lit);
done:
  free(files_v);
  free(files_se);
  recon_imaging_release(&im);
  hetinv_context_destroy(&ctx);
  return status;
}
