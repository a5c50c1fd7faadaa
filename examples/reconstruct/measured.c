/* Acquisition from files: the render scene's measurement set (render/scene.c,
 * the same reader as hetinv-render) and the EXR files of its rows, in the
 * layout hetinv-render writes (render/output.c): per row <row>.exr with
 * one channel per pathlength bin ("L" or "tau0000" ...), sensor width ×
 * height pixels, row 0 of the image the highest v; standard errors in
 * <row>_stderr.exr. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "faces.h"
#include "recon.h"
#include "scene.h"

/* Whether two lengths agree to within what a float attribute keeps. */
static bool same_length(double a, double b) { return fabs(a - b) <= 1e-6 * fmax(fabs(a), fabs(b)); }

/* A file hetinv-render wrote describes its row (render/output.c): where it
 * does, the description must be the render scene's, else the file was
 * written for another scene (bins of another width, another unit, another
 * face) and its values would be fitted under the wrong model. Attributes a
 * file lacks (an instrument's) are not required. */
static int check_description(const hetinv_image_t *img, const scene_t *scene, int row, const char *file, char *msg,
                             size_t msg_size) {
  const scene_row_t *rw = &scene->rows[row];
  const scene_sensor_t *s = &scene->sensors[rw->sensor];
  const scene_pathlength_t *pl = &scene->pathlengths[rw->pathlength];
  const char *text = NULL, *want = NULL, *key = NULL;
  const char *const strings[][2] = {{"hetinv:lengthUnit", scene->unit},
                                    {"hetinv:sensorFace", face_names[s->face]},
                                    {"hetinv:pathlengthType", pl->steady ? "steady" : "bins"}};
  for (size_t i = 0; key == NULL && i < sizeof strings / sizeof strings[0]; ++i) {
    if (hetinv_image_get_attribute_string(img, strings[i][0], &text) == HETINV_SUCCESS && strcmp(text, strings[i][1]) != 0) {
      key = strings[i][0];
      want = strings[i][1];
    }
  }
  if (key != NULL) {
    snprintf(msg, msg_size, "%s: its attribute %s is \"%s\", but measurement row %d \"%s\" of the render scene "
             "has \"%s\": the file was written for another scene", file, key, text, row, rw->name, want);
    return -1;
  }
  int32_t count = 0;
  double width = 0.0, size[2] = {0.0, 0.0};
  if (hetinv_image_get_attribute_int(img, "hetinv:binCount", &count) == HETINV_SUCCESS && count != pl->count) {
    snprintf(msg, msg_size, "%s: its attribute hetinv:binCount is %d, but measurement row %d \"%s\" of the render "
             "scene has %d bins: the file was written for another scene", file, (int)count, row, rw->name,
             (int)pl->count);
    return -1;
  }
  if (!pl->steady && hetinv_image_get_attribute_double(img, "hetinv:binWidth", &width) == HETINV_SUCCESS &&
      !same_length(width, pl->width)) {
    snprintf(msg, msg_size, "%s: its attribute hetinv:binWidth is %.9g, but measurement row %d \"%s\" of the render "
             "scene has bins %.9g wide: the file was written for another scene", file, width, row, rw->name,
             pl->width);
    return -1;
  }
  if (hetinv_image_get_attribute_string(img, "hetinv:pixelSize", &text) == HETINV_SUCCESS &&
      sscanf(text, "[%lf, %lf]", &size[0], &size[1]) == 2 &&
      !(same_length(size[0], s->pixel_size[0]) && same_length(size[1], s->pixel_size[1]))) {
    snprintf(msg, msg_size, "%s: its attribute hetinv:pixelSize is %s, but measurement row %d \"%s\" of the render "
             "scene has pixels of [%.9g, %.9g]: the file was written for another scene", file, text, row, rw->name,
             s->pixel_size[0], s->pixel_size[1]);
    return -1;
  }
  return 0;
}

/* Reads one stack of a row into dst (the row's values in the set's layout:
 * bin-major, then pixel j·width + i, j from the lowest v). Non-finite
 * values, and negative ones when `std_errors`, are refused. */
static int read_stack(hetinv_context_t *ctx, const scene_t *scene, int row, size_t offset,
                      const char *file, bool std_errors, double *dst, char *msg, size_t msg_size) {
  const scene_row_t *rw = &scene->rows[row];
  const scene_sensor_t *s = &scene->sensors[rw->sensor];
  const scene_pathlength_t *pl = &scene->pathlengths[rw->pathlength];
  hetinv_image_t *img = NULL;
  if (hetinv_image_read_exr(ctx, file, &img) != HETINV_SUCCESS) {
    /* the library's message names the file and the reason (cannot open, corrupt) */
    snprintf(msg, msg_size, "measurement row %d \"%s\": %s", row, rw->name,
             hetinv_context_last_error_message(ctx));
    return -1;
  }
  int32_t w = 0, h = 0, channels = 0;
  hetinv_image_get_size(img, &w, &h, &channels);
  int status = -1;
  char name[32];
  scene_channel_name(pl, pl->count - 1, name, sizeof name);
  if (channels < pl->count) { /* more are fine: each bin's channel is found by name, others ignored */
    snprintf(msg, msg_size, "%s: %d channel%s; measurement row %d \"%s\" has %d pathlength bin%s "
             "(pathlength \"%s\"), so expected channels %s%s%s", file, (int)channels,
             channels == 1 ? "" : "s", row, rw->name, (int)pl->count, pl->count == 1 ? "" : "s",
             pl->name, pl->steady ? "" : "tau0000 ... ", name, pl->steady ? " (steady state)" : "");
  } else if (w != s->width || h != s->height) {
    snprintf(msg, msg_size, "%s: %d x %d pixels; measurement row %d \"%s\" has sensor \"%s\" of "
             "%d x %d pixels", file, (int)w, (int)h, row, rw->name, s->name, (int)s->width,
             (int)s->height);
  } else {
    status = check_description(img, scene, row, file, msg, msg_size);
  }
  const size_t pixels = (size_t)w * (size_t)h;
  for (int32_t b = 0; status == 0 && b < pl->count; ++b) {
    int32_t c = -1;
    scene_channel_name(pl, b, name, sizeof name);
    if (hetinv_image_find_channel(img, name, &c) != HETINV_SUCCESS) {
      snprintf(msg, msg_size, "%s: no channel \"%s\" (bin %d of measurement row %d \"%s\"); "
               "its first channel is \"%s\"", file, name, (int)b, row, rw->name,
               hetinv_image_channel_name(img, 0));
      status = -1;
      break;
    }
    const float *px = hetinv_image_channel_data(img, c);
    for (int32_t y = 0; status == 0 && y < h; ++y) {
      for (int32_t x = 0; x < w; ++x) {
        double v = (double)px[(size_t)y * (size_t)w + (size_t)x];
        if (!isfinite(v) || (std_errors && v < 0.0)) {
          snprintf(msg, msg_size, "%s: channel \"%s\", pixel (%d, %d) of measurement row %d \"%s\": "
                   "%s is %g; expected a finite %s", file, name, (int)x, (int)y, row, rw->name,
                   std_errors ? "standard error" : "value", v,
                   std_errors ? "number >= 0" : "number");
          status = -1;
          break;
        }
        /* image row y holds the set's pixel row h - 1 - y (render/output.c) */
        dst[offset + (size_t)b * pixels + (size_t)(h - 1 - y) * (size_t)w + (size_t)x] = v;
      }
    }
  }
  hetinv_image_destroy(&img);
  return status;
}

/* Checks the rows: each must have a file layout (an orthographic sensor). */
static int check_rows(const scene_t *scene, char *msg, size_t msg_size) {
  for (int i = 0; i < scene->row_count; ++i) {
    const scene_sensor_t *s = &scene->sensors[scene->rows[i].sensor];
    if (s->kind != SENSOR_ORTHOGRAPHIC) {
      snprintf(msg, msg_size, "%s: measurement row %d \"%s\": sensor \"%s\" is %s; "
               "hetinv-render writes no file for it, so a reconstruction from files reads "
               "orthographic sensors only", scene->path, i, scene->rows[i].name, s->name,
               scene_sensor_type(s->kind));
      return -1;
    }
  }
  return 0;
}

/* Reads every row's values (and standard errors) and sets them, with
 * weights and a mask (dark rows and unresolved values out), on the set;
 * then masks values at or above sc->saturation (their count in
 * sc->saturated). */
static int read_values(hetinv_context_t *ctx, recon_scene_t *sc, const scene_t *scene,
                       char *msg, size_t msg_size) {
  size_t n = hetinv_measurements_value_count(scene->set);
  double *v = calloc(n, sizeof *v), *se = calloc(n, sizeof *se), *w = calloc(n, sizeof *w);
  uint8_t *mask = malloc(n);
  int status = 0;
  if (v == NULL || se == NULL || w == NULL || mask == NULL) {
    snprintf(msg, msg_size, "out of memory for %zu measured values", n);
    status = -1;
  }
  char file[2400];
  for (int row = 0; status == 0 && row < scene->row_count; ++row) {
    size_t offset = 0;
    int32_t pixels = 0, bins = 0;
    hetinv_measurements_row_layout(scene->set, row, &offset, &pixels, &bins);
    snprintf(file, sizeof file, "%s/%s.exr", sc->measured, scene->rows[row].name);
    status = read_stack(ctx, scene, row, offset, file, false, v, msg, msg_size);
    if (status == 0 && sc->std_errors[0] != '\0') {
      snprintf(file, sizeof file, "%s/%s_stderr.exr", sc->std_errors, scene->rows[row].name);
      status = read_stack(ctx, scene, row, offset, file, true, se, msg, msg_size);
    }
  }
  hetinv_result_t r = HETINV_SUCCESS;
  if (status == 0) {
    memset(mask, 1, n);
    sc->dark_rows = 0;
    /* A row that no photon reached, zeros with zero errors (as hetinv-render
     * writes it, camera or not), is left out as the simulated acquisition
     * leaves it out: with no error its weight would be arbitrary. Without
     * error files a dark row stays (its weights are not the errors'). */
    for (int row = 0; sc->std_errors[0] != '\0' && row < scene->row_count; ++row) {
      size_t offset = 0;
      int32_t pixels = 0, bins = 0;
      hetinv_measurements_row_layout(scene->set, row, &offset, &pixels, &bins);
      size_t len = (size_t)pixels * (size_t)bins;
      bool dark = true;
      for (size_t i = offset; dark && i < offset + len; ++i) dark = v[i] == 0.0 && se[i] == 0.0;
      if (dark) memset(mask + offset, 0, len);
      sc->dark_rows += dark;
    }
    recon_mask_unresolved(v, se, mask, n, sc->min_snr);
    recon_set_weights(sc->weighting, v, se, NULL, w, n);
    r = hetinv_measurements_set_values(scene->set, v, se, n);
    if (r == HETINV_SUCCESS) r = hetinv_measurements_set_weights(scene->set, w, n);
    if (r == HETINV_SUCCESS) r = hetinv_measurements_set_mask(scene->set, mask, n);
    sc->saturated = 0;
    if (r == HETINV_SUCCESS && isfinite(sc->saturation)) {
      r = hetinv_measurements_mask_saturated(scene->set, sc->saturation, &sc->saturated);
    }
    if (r != HETINV_SUCCESS) {
      snprintf(msg, msg_size, "%s: %s", sc->measured, hetinv_context_last_error_message(ctx));
      status = -1;
    }
  }
  free(v);
  free(se);
  free(w);
  free(mask);
  return status;
}

static void release_scene(scene_t *scene) {
  scene_destroy(scene);
  free(scene);
}

int recon_files_load(hetinv_context_t *ctx, recon_scene_t *sc, recon_imaging_t *im, char *msg,
                     size_t msg_size) {
  memset(im, 0, sizeof *im);
  scene_t *scene = calloc(1, sizeof *scene);
  if (scene == NULL) {
    snprintf(msg, msg_size, "out of memory");
    return -1;
  }
  im->files = scene;
  im->files_release = release_scene;
  jr_t jr;
  memset(&jr, 0, sizeof jr);
  /* The render scene's own messages name its file and key; the note says
   * why that file was read (a mistyped acquisition.render_scene may name
   * the reconstruction scene itself). */
  bool failed = scene_load(scene, sc->render_scene, &jr) < 0;
  if (!failed) {
    scene->geometry_only = 1; /* the medium's values (the truth, if any) are never read */
    failed = scene_build(scene, ctx, &jr) < 0;
  }
  if (failed) {
    snprintf(msg, msg_size, "%s (the file acquisition.render_scene names, read as a render scene: docs/scene-format.md)",
             jr.message);
    return -1;
  }
  if (check_rows(scene, msg, msg_size) < 0) return -1;
  memcpy(sc->grid, scene->dims, sizeof sc->grid);
  memcpy(sc->box_min, scene->box_min, sizeof sc->box_min);
  memcpy(sc->box_max, scene->box_max, sizeof sc->box_max);
  sc->has_box = true;
  sc->eta = scene->eta;
  sc->eta_out = scene->eta_out;
  sc->size = scene->box_max[0] - scene->box_min[0]; /* layer-wise stages' voxel size: size / grid[0] */
  if (read_values(ctx, sc, scene, msg, msg_size) < 0) return -1;
  im->set = scene->set; /* the set is released with the imaging, the rest with the scene */
  scene->set = NULL;
  return 0;
}

