/* The scene's camera: its noise model applied row by row (camera.h). */
#include "camera.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

hetinv_result_t camera_shoot_row(hetinv_context_t *ctx, const hetinv_noise_model_t *model,
                                 const hetinv_measurements_t *set, int32_t row, const double *clean, double *out,
                                 double *camera_se, double *exposure, bool *lit) {
  size_t off = 0;
  int32_t pixels = 0, bins = 0;
  *lit = false;
  hetinv_result_t r = hetinv_measurements_row_layout(set, row, &off, &pixels, &bins);
  size_t len = (size_t)pixels * (size_t)bins;
  for (size_t i = 0; r == HETINV_SUCCESS && i < len; ++i) *lit = *lit || clean[i] > 0.0;
  if (r != HETINV_SUCCESS || !*lit) return r;
  hetinv_noise_model_t shot = *model;
  shot.first_index = off;
  return hetinv_noise_apply(ctx, &shot, clean, out, camera_se, len, exposure);
}

int camera_record(const scene_t *sc, hetinv_context_t *ctx, double *values, double *std_errors, jr_t *jr) {
  if (!sc->has_noise) return 0;
  double *camera = NULL; /* one row's camera errors */
  size_t capacity = 0;
  int status = 0;
  for (int row = 0; status == 0 && row < sc->row_count; ++row) {
    size_t off = 0;
    int32_t pixels = 0, bins = 0;
    bool lit = false;
    hetinv_result_t r = hetinv_measurements_row_layout(sc->set, row, &off, &pixels, &bins);
    size_t len = (size_t)pixels * (size_t)bins;
    if (r == HETINV_SUCCESS && len > capacity) {
      free(camera);
      camera = malloc(len * sizeof *camera);
      capacity = camera ? len : 0;
      if (camera == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
    }
    double *v = values + off, *se = std_errors + off;
    if (r == HETINV_SUCCESS) r = camera_shoot_row(ctx, &sc->noise, sc->set, row, v, v, camera, NULL, &lit);
    if (r != HETINV_SUCCESS) {
      char at[3 * SCENE_NAME_MAX + 32];
      snprintf(at, sizeof at, "noise (row %s)", sc->rows[row].name);
      status = scene_lib_fail(jr, at, ctx, r);
      break;
    }
    /* As the simulated acquisition combines them (hypot(camera, render)). */
    for (size_t i = 0; lit && i < len; ++i) se[i] = hypot(camera[i], se[i]);
  }
  free(camera);
  return status;
}
