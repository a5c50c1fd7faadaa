/* Presets as files: a simulated configuration (the built-in scene, a Fig. 4
 * cell, Fig. 5) written out in the one scene vocabulary every program
 * reads, so that a user can edit it, render it with hetinv-render and
 * reconstruct from the files with hetinv-reconstruct:
 *
 *   render.json        the render scene (docs/scene-format.md): the truth
 *                      as its medium, one ideal beam per source, the
 *                      orthographic sensors, the pathlength windows and the
 *                      rows, with the photons, seed and stream of the
 *                      simulated render, so its images hold the same values
 *   truth_<param>.vol  the truth
 *   reconstruct.json   the reconstruction from <dir>/data (files mode,
 *                      docs/reconstruct-format.md), with the preset's
 *                      estimator and optimizer
 *
 * Numbers are printed with the fewest digits (15 to 17) that read back to
 * the same double, so the written scene builds the same emitters, sensors
 * and bins, bit for bit. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "faces.h"
#include "recon.h"

/* A JSON string (names are free text). */
static void put_string(FILE *f, const char *s) {
  fputc('"', f);
  for (; *s; ++s) {
    unsigned char c = (unsigned char)*s;
    if (c == '"' || c == '\\') {
      fprintf(f, "\\%c", c);
    } else if (c < 0x20) {
      fprintf(f, "\\u%04x", c);
    } else {
      fputc(c, f);
    }
  }
  fputc('"', f);
}

/* The shortest of 15 to 17 significant digits that reads back to x. */
static void put_number(FILE *f, double x) {
  char text[40];
  for (int digits = 15; digits <= 17; ++digits) {
    snprintf(text, sizeof text, "%.*g", digits, x);
    if (strtod(text, NULL) == x) break;
  }
  fputs(text, f);
}

/* before, then "key": x. */
static void put_member(FILE *f, const char *before, const char *key, double x) {
  fprintf(f, "%s\"%s\": ", before, key);
  put_number(f, x);
}

static void put_numbers(FILE *f, const double *v, int n) {
  fputc('[', f);
  for (int i = 0; i < n; ++i) {
    if (i) fputs(", ", f);
    put_number(f, v[i]);
  }
  fputc(']', f);
}

static void sensor_name(char *out, size_t n, const recon_imaging_t *im, int32_t s) {
  snprintf(out, n, "s%d_%s", (int)s, face_names[im->sensor_specs[s].face]);
}

static void write_render_scene(FILE *f, const recon_scene_t *sc, const recon_imaging_t *im) {
  fprintf(f, "{\n  \"description\": ");
  put_string(f, sc->name);
  fprintf(f, ",\n  \"unit\": \"mm\",\n  \"box\": {\"min\": ");
  double lo[3] = {0, 0, 0}, hi[3] = {sc->size, sc->size, sc->size};
  if (sc->has_box) {
    memcpy(lo, sc->box_min, sizeof lo);
    memcpy(hi, sc->box_max, sizeof hi);
  }
  put_numbers(f, lo, 3);
  fprintf(f, ", \"max\": ");
  put_numbers(f, hi, 3);
  put_member(f, "},\n  ", "eta", sc->eta);
  put_member(f, ",\n  ", "eta_out", sc->has_box ? sc->eta_out : 1.0);
  fprintf(f, ",\n");
  fprintf(f, "  \"medium\": {\"vol\": {\"sigma_a\": \"truth_sigma_a.vol\", \"sigma_s\": \"truth_sigma_s.vol\", "
             "\"g\": \"truth_g.vol\"}},\n  \"emitters\": [\n");
  for (int32_t e = 0; e < im->emitter_count; ++e) {
    fprintf(f, "    {\"name\": \"e%d\", \"type\": \"ideal\", \"origin\": ", (int)e);
    put_numbers(f, im->emitter_specs[e].origin, 3);
    fprintf(f, ", \"direction\": ");
    put_numbers(f, im->emitter_specs[e].direction, 3);
    fprintf(f, "}%s\n", e + 1 < im->emitter_count ? "," : "");
  }
  fprintf(f, "  ],\n  \"sensors\": [\n");
  for (int32_t s = 0; s < im->sensor_count; ++s) {
    const recon_sensor_spec_t *sp = &im->sensor_specs[s];
    char name[64];
    sensor_name(name, sizeof name, im, s);
    fprintf(f, "    {\"name\": \"%s\", \"type\": \"orthographic\", \"face\": \"%s\", \"direction\": ", name,
            face_names[sp->face]);
    put_numbers(f, sp->direction, 3);
    fprintf(f, ", \"origin\": ");
    put_numbers(f, sp->origin, 2);
    fprintf(f, ", \"pixel_size\": ");
    put_numbers(f, sp->pixel, 2);
    fprintf(f, ", \"width\": %d, \"height\": %d}%s\n", (int)sp->width, (int)sp->height,
            s + 1 < im->sensor_count ? "," : "");
  }
  fprintf(f, "  ],\n  \"pathlengths\": [\n    {\"name\": \"steady\", \"type\": \"steady\"}");
  if (im->bin_count > 0) {
    fprintf(f, ",\n    {\"name\": \"bins\", \"type\": \"bins\", \"window\": \"box\"");
    put_member(f, ", ", "width", im->bin_width);
    fprintf(f, ", \"count\": %d}", (int)im->bin_count);
  }
  fprintf(f, "\n  ],\n  \"measurements\": [\n");
  for (int32_t r = 0; r < im->row_count; ++r) {
    const recon_row_spec_t *row = &im->row_specs[r];
    char sensor[64];
    sensor_name(sensor, sizeof sensor, im, row->sensor);
    fprintf(f, "    {\"name\": \"e%d_%s\", \"emitter\": \"e%d\", \"sensor\": \"%s\", \"pathlength\": \"%s\"}%s\n",
            (int)row->emitter, sensor, (int)row->emitter, sensor, row->bins ? "bins" : "steady",
            r + 1 < im->row_count ? "," : "");
  }
  /* The simulated render's photons, seed and stream: the same values. */
  fprintf(f, "  ],\n  \"photons\": %lld,\n  \"seed\": %llu,\n  \"estimator\": {\"stream\": %d}",
          (long long)sc->truth_photons, (unsigned long long)sc->seed, RECON_TRUTH_STREAM);
  /* And its camera: the same draws, value by value (recon_simulate). */
  if (sc->noise) {
    const hetinv_noise_model_t *m = &sc->noise_model;
    put_member(f, ",\n  \"noise\": {", "full_well", m->full_well);
    put_member(f, ", ", "read_noise", m->read_noise);
    put_member(f, ", ", "exposure", m->exposure);
    put_member(f, ", ", "auto_level", m->auto_level);
    fprintf(f, ", \"seed\": %llu}", (unsigned long long)m->seed);
  }
  fprintf(f, "\n}\n");
}

static void write_reconstruct_scene(FILE *f, const recon_scene_t *sc, const recon_imaging_t *im) {
  (void)im; /* it names the render scene instead */
  char name[160];
  snprintf(name, sizeof name, "%s, from files", sc->name);
  fprintf(f, "{\n  \"name\": ");
  put_string(f, name);
  fprintf(f, ",\n  \"acquisition\": {\"render_scene\": \"render.json\", \"measured\": \"data\", "
             "\"std_errors\": \"data\", \"weighting\": \"%s\", \"min_snr\": ", recon_weighting_names[sc->weighting]);
  put_number(f, sc->min_snr);
  fprintf(f, "},\n");
  fprintf(f, "  \"truth\": {\"vol\": {\"sigma_a\": \"truth_sigma_a.vol\", \"sigma_s\": \"truth_sigma_s.vol\", "
             "\"g\": \"truth_g.vol\"}},\n");
  fprintf(f, "  \"estimator\": {\"photons\": %lld, \"batches\": %d", (long long)sc->photons, (int)sc->batches);
  if (sc->loss_clip > 0.0) put_member(f, ", ", "loss_clip", sc->loss_clip);
  fprintf(f, "},\n");
  fprintf(f, "  \"optimizer\": {\"method\": \"%s\", \"coordinates\": \"%s\", \"iterations\": %lld,\n",
          recon_method_names[sc->method], recon_coordinate_names[sc->coordinates], (long long)sc->iterations);
  put_member(f, "                ", "coarse_fraction", sc->coarse_fraction);
  fprintf(f, ", \"minibatch\": %d", (int)sc->minibatch);
  put_member(f, ", ", "epsilon", sc->epsilon);
  if (sc->epsilon_start > 0.0) put_member(f, ", ", "epsilon_start", sc->epsilon_start);
  if (sc->coarse_epsilon_start > 0.0) put_member(f, ", ", "coarse_epsilon_start", sc->coarse_epsilon_start);
  if (sc->settle_epsilon > 0.0) put_member(f, ", ", "settle_epsilon", sc->settle_epsilon);
  if (sc->settle_photons > 0.0) put_member(f, ", ", "settle_photons", sc->settle_photons);
  if (sc->settle_fraction > 0.0) put_member(f, ", ", "settle_fraction", sc->settle_fraction);
  put_member(f, ", ", "decay", sc->decay);
  put_member(f, ",\n                ", "learning_rate", sc->learning_rate);
  if (sc->method == HETINV_METHOD_ADAM) {
    put_member(f, ", ", "beta1", sc->beta1);
    put_member(f, ", ", "beta2", sc->beta2);
  }
  fprintf(f, ", \"average_window\": %d, ", (int)sc->average_window);
  if (sc->coarse_average_window > 0) fprintf(f, "\"coarse_average_window\": %d, ", (int)sc->coarse_average_window);
  put_member(f, "", "time_budget", sc->time_budget);
  if (sc->smoothness > 0.0) put_member(f, ", ", "smoothness", sc->smoothness);
  if (sc->multiscale > 0.0) put_member(f, ", ", "multiscale", sc->multiscale);
  /* Always written: the reader's default (0.1) is not the library's 0. */
  put_member(f, ", ", "box_margin", sc->box_margin);
  if (sc->stage_results) fprintf(f, ", \"stage_results\": true");
  fprintf(f, ",\n");
  fprintf(f, "                \"bounds\": {");
  for (int p = 0; p < 3; ++p) {
    double b[2] = {sc->bounds_lo[p], sc->bounds_hi[p]};
    fprintf(f, "%s\"%s\": ", p ? ", " : "", hetinv_param_name((hetinv_param_t)p));
    put_numbers(f, b, 2);
  }
  fprintf(f, "},\n                \"init\": ");
  if (sc->init_at_truth) {
    fprintf(f, "\"truth\"");
  } else {
    put_numbers(f, sc->init, 3);
  }
  double levels[RECON_MAX_LEVELS];
  for (int32_t i = 0; i < sc->level_count; ++i) levels[i] = sc->levels[i];
  fprintf(f, ", \"levels\": ");
  put_numbers(f, levels, sc->level_count);
  fprintf(f, ", \"layerwise_layers\": %d},\n", (int)sc->layerwise_layers);
  fprintf(f, "  \"seed\": %llu,\n  \"threads\": %d\n}\n", (unsigned long long)sc->seed, (int)sc->threads);
}

/* Writes <dir>/<file> whole or not at all with write(f, sc, im). */
static int write_text(const char *dir, const char *file,
                      void (*write)(FILE *, const recon_scene_t *, const recon_imaging_t *),
                      const recon_scene_t *sc, const recon_imaging_t *im, char *msg, size_t n) {
  char path[1200], tmp[1300];
  snprintf(path, sizeof path, "%s/%s", dir, file);
  FILE *f = text_file_begin(path, tmp, sizeof tmp);
  if (f == NULL) {
    snprintf(msg, n, "%s: %s", path, strerror(errno));
    return -1;
  }
  write(f, sc, im);
  if (text_file_commit(f, tmp, path) != 0) {
    snprintf(msg, n, "%s: %s", path, strerror(errno));
    return -1;
  }
  return 0;
}

int recon_preset_write(hetinv_context_t *ctx, const recon_scene_t *sc, const hetinv_medium_t *truth, const recon_imaging_t *im,
                       const char *dir, char *msg, size_t n) {
  if (im->emitter_specs == NULL || im->row_count != hetinv_measurements_row_count(im->set)) {
    snprintf(msg, n, "%s: only a simulated configuration (medium, imaging) is written as a preset", dir);
    return -1;
  }
  /* The files scene reads measured data, whose render variance is unknown. */
  if (sc->loss_clip_errors != RECON_CLIP_DATA) {
    snprintf(msg, n, "estimator.loss_clip_errors: \"%s\" needs simulated data, and a preset reads its data from "
             "files; write it with \"data\"", recon_clip_errors_names[sc->loss_clip_errors]);
    return -1;
  }
  if (sc->min_snr_errors != RECON_SNR_DATA) {
    snprintf(msg, n, "acquisition.min_snr_errors: \"%s\" needs simulated data, and a preset reads its data from "
             "files; write it with \"data\"", recon_snr_errors_names[sc->min_snr_errors]);
    return -1;
  }
  /* hetinv-render writes the render's errors and its camera's by the plain
   * noise model: these variants of the simulation's errors have no file form. */
  if ((sc->noise && sc->expected_camera_errors) || sc->pooled_errors || sc->independent_errors) {
    snprintf(msg, n, "acquisition.%s: the simulation's variant of its errors has no file form (hetinv-render "
             "writes the render's errors, and its camera's by the plain noise model); write the preset without it",
             sc->pooled_errors ? "pooled_errors" : sc->independent_errors ? "independent_errors" : "expected_camera_errors");
    return -1;
  }
  if (sc->noise && sc->noise_model.seed > (UINT64_C(1) << 53)) {
    snprintf(msg, n, "acquisition.seed: %llu is above 2^53, the largest a render scene holds (use a smaller one)",
             (unsigned long long)sc->noise_model.seed);
    return -1;
  }
  /* The render scene's seed is a JSON integer, exact up to 2^53. */
  if (sc->seed > (UINT64_C(1) << 53)) {
    snprintf(msg, n, "seed: %llu is above 2^53, the largest a render scene holds (use a smaller one)",
             (unsigned long long)sc->seed);
    return -1;
  }
  for (int p = 0; p < 3; ++p) {
    char path[1200];
    snprintf(path, sizeof path, "%s/truth_%s.vol", dir, hetinv_param_name((hetinv_param_t)p));
    if (hetinv_medium_write_vol(truth, (hetinv_param_t)p, path) != HETINV_SUCCESS) {
      snprintf(msg, n, "%s: %s", path, hetinv_context_last_error_message(ctx));
      return -1;
    }
  }
  if (write_text(dir, "render.json", write_render_scene, sc, im, msg, n) < 0) return -1;
  return write_text(dir, "reconstruct.json", write_reconstruct_scene, sc, im, msg, n);
}
