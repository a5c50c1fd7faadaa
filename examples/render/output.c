/* OpenEXR stacks, PNG previews and totals of a rendered scene. */
#include "output.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Longest string attribute an image holds. */
#define ATTRIBUTE_MAX 65535

typedef enum { STACK_VALUES = 0, STACK_STD_ERRORS = 1, STACK_BALLISTIC = 2 } stack_kind_t;

/* Integrated totals of a row: per bin and summed over bins. */
typedef struct row_totals {
  size_t offset;
  int32_t pixels, bins;
  double area;              /* pixel area (1 for a hemispherical detector or a fiber) */
  double value, std_error, ballistic; /* over all bins */
  int std_error_exact;      /* 0: std_error is an upper bound */
  double *bin_value, *bin_std_error, *bin_ballistic;
} row_totals_t;

static void row_totals_free(row_totals_t *t) {
  free(t->bin_value);
  memset(t, 0, sizeof *t);
}

/* Totals of a row. Values of different pixels and bins come from the same
 * photons, so the error of a sum is bounded by the sum of the errors. */
static int row_totals(const scene_t *sc, const render_result_t *res, int row, row_totals_t *t) {
  memset(t, 0, sizeof *t);
  if (hetinv_measurements_row_layout(sc->set, row, &t->offset, &t->pixels, &t->bins) != HETINV_SUCCESS) {
    return -1;
  }
  const scene_sensor_t *s = &sc->sensors[sc->rows[row].sensor];
  t->area = s->kind == SENSOR_ORTHOGRAPHIC ? s->pixel_size[0] * s->pixel_size[1] : 1.0;
  t->bin_value = calloc((size_t)t->bins * 3, sizeof(double));
  if (t->bin_value == NULL) return -1;
  t->bin_std_error = t->bin_value + t->bins;
  t->bin_ballistic = t->bin_value + 2 * (size_t)t->bins;
  for (int32_t b = 0; b < t->bins; ++b) {
    for (int32_t p = 0; p < t->pixels; ++p) {
      size_t k = t->offset + (size_t)b * (size_t)t->pixels + (size_t)p;
      t->bin_value[b] += res->values[k] * t->area;
      t->bin_std_error[b] += res->std_errors[k] * t->area;
      t->bin_ballistic[b] += res->ballistic[k] * t->area;
    }
    t->value += t->bin_value[b];
    t->std_error += t->bin_std_error[b];
    t->ballistic += t->bin_ballistic[b];
  }
  t->std_error_exact = t->pixels == 1 && t->bins == 1;
  return 0;
}

/* "[a, b, c]" of n numbers; returns 0 if it did not fit. */
static int format_vector(char *out, size_t size, const double *x, int n) {
  size_t used = 0;
  for (int i = 0; i < n; ++i) {
    int w = snprintf(out + used, size - used, "%s%.15g", i == 0 ? "[" : ", ", x[i]);
    if (w < 0 || (size_t)w >= size - used) return 0;
    used += (size_t)w;
  }
  if (used + 2 > size) return 0;
  memcpy(out + used, "]", 2);
  return 1;
}

/* Attribute setters that do nothing after a failure; *name_out is the failing one. */
typedef struct attrs {
  hetinv_image_t *image;
  hetinv_result_t result;
  const char *failed;
} attrs_t;

static void attr_s(attrs_t *a, const char *name, const char *value) {
  if (a->result != HETINV_SUCCESS) return;
  a->result = hetinv_image_set_attribute_string(a->image, name, value);
  if (a->result != HETINV_SUCCESS) a->failed = name;
}
static void attr_d(attrs_t *a, const char *name, double value) {
  if (a->result != HETINV_SUCCESS) return;
  a->result = hetinv_image_set_attribute_double(a->image, name, value);
  if (a->result != HETINV_SUCCESS) a->failed = name;
}
static void attr_i(attrs_t *a, const char *name, int32_t value) {
  if (a->result != HETINV_SUCCESS) return;
  a->result = hetinv_image_set_attribute_int(a->image, name, value);
  if (a->result != HETINV_SUCCESS) a->failed = name;
}
static void attr_vec(attrs_t *a, const char *name, const double *x, int n) {
  char buf[256];
  if (format_vector(buf, sizeof buf, x, n)) attr_s(a, name, buf);
}
/* A scene object's JSON text, when it fits in an attribute. */
static void attr_json(attrs_t *a, const char *name, const cJSON *json) {
  if (json == NULL) return;
  char *text = cJSON_PrintUnformatted(json);
  if (text != NULL && strlen(text) <= ATTRIBUTE_MAX) attr_s(a, name, text);
  cJSON_free(text);
}

/* The attributes that make a row's files describe themselves. */
static void set_attributes(attrs_t *a, const scene_t *sc, const render_result_t *res, int row,
                           stack_kind_t kind, int has_ballistic) {
  const scene_row_t *rw = &sc->rows[row];
  const scene_emitter_t *e = &sc->emitters[rw->emitter];
  const scene_sensor_t *s = &sc->sensors[rw->sensor];
  const scene_pathlength_t *pl = &sc->pathlengths[rw->pathlength];
  char buf[512];
  static const char *const contents[] = {
      "Monte Carlo estimate of the radiance leaving the face toward the sensor, per unit "
      "emitted power, one channel per pathlength bin; ballistic light excluded",
      "standard error of each value of the image of the same name without _stderr",
      "ballistic (never scattered) light leaving each pixel exactly along the sensor direction: "
      "power per unit area per unit emitted power, the coefficient of a Dirac in direction"};
  static const char *const recorded[] = {
      "a simulated camera's recording (the scene's \"noise\", attribute hetinv:noise) of the Monte Carlo "
      "estimate of the radiance leaving the face toward the sensor, per unit emitted power, one channel per "
      "pathlength bin; ballistic light excluded",
      "standard error of each value of the image of the same name without _stderr: the camera's and the "
      "Monte Carlo estimate's combined, hypot(camera, render)"};
  attr_s(a, "hetinv:content", sc->has_noise && kind != STACK_BALLISTIC ? recorded[kind] : contents[kind]);
  if (sc->has_noise && kind != STACK_BALLISTIC) attr_json(a, "hetinv:noise", cJSON_GetObjectItemCaseSensitive(sc->root, "noise"));
  attr_s(a, "hetinv:libraryVersion", hetinv_version_string());
  attr_s(a, "hetinv:scene", sc->path);
  attr_s(a, "hetinv:row", rw->name);
  /* medium */
  attr_s(a, "hetinv:lengthUnit", sc->unit);
  attr_d(a, "hetinv:eta", sc->eta);
  attr_d(a, "hetinv:etaOut", sc->eta_out);
  attr_vec(a, "hetinv:boxMin", sc->box_min, 3);
  attr_vec(a, "hetinv:boxMax", sc->box_max, 3);
  const double dims[3] = {sc->dims[0], sc->dims[1], sc->dims[2]};
  attr_vec(a, "hetinv:mediumDims", dims, 3);
  attr_s(a, "hetinv:mediumKind", sc->medium_kind);
  attr_json(a, "hetinv:mediumJson", jr_get(sc->root, "medium"));
  /* emitter */
  attr_s(a, "hetinv:emitter", e->name);
  attr_s(a, "hetinv:emitterType", e->type);
  attr_json(a, "hetinv:emitterJson", e->json);
  /* sensor */
  int u, v;
  scene_face_axes(s->face, &u, &v);
  attr_s(a, "hetinv:sensor", s->name);
  attr_s(a, "hetinv:sensorType", "orthographic");
  attr_s(a, "hetinv:sensorFace", face_names[s->face]);
  attr_vec(a, "hetinv:sensorDirection", s->direction, 3);
  attr_vec(a, "hetinv:sensorOrigin", s->origin, 2);
  attr_vec(a, "hetinv:pixelSize", s->pixel_size, 2);
  snprintf(buf, sizeof buf, "column i covers %c from origin[0] + i*pixelSize[0]; row 0 is the "
           "highest %c (row y covers %c from origin[1] + (height-1-y)*pixelSize[1])",
           "xyz"[u], "xyz"[v], "xyz"[v]);
  attr_s(a, "hetinv:pixelLayout", buf);
  if (kind == STACK_BALLISTIC) {
    snprintf(buf, sizeof buf, "power per unit area per unit emitted power: 1/%s^2 "
             "(the coefficient of a Dirac in direction)", sc->unit);
  } else {
    snprintf(buf, sizeof buf, "radiance per unit emitted power: 1/(%s^2 sr)", sc->unit);
  }
  attr_s(a, "hetinv:valueUnit", buf);
  if (kind != STACK_BALLISTIC) {
    snprintf(buf, sizeof buf, "excluded; %s", has_ballistic ? "see the _ballistic image"
                                                            : "none reached this sensor");
    attr_s(a, "hetinv:ballistic", buf);
  }
  /* pathlength */
  attr_s(a, "hetinv:pathlength", pl->name);
  attr_s(a, "hetinv:pathlengthType", pl->steady ? "steady" : "bins");
  attr_i(a, "hetinv:binCount", pl->count);
  if (!pl->steady) {
    attr_s(a, "hetinv:binWindow", pl->window == HETINV_WINDOW_BOX ? "box" : "gaussian");
    attr_d(a, "hetinv:binWidth", pl->width);
    int uniform = pl->count > 1;
    double spacing = pl->count > 1 ? pl->centres[1] - pl->centres[0] : 0.0;
    for (int32_t i = 1; uniform && i < pl->count; ++i) {
      uniform = fabs(pl->centres[i] - (pl->centres[0] + i * spacing)) <= 1e-9 * fmax(1.0, fabs(pl->centres[i]));
    }
    attr_d(a, "hetinv:binFirstCentre", pl->centres[0]);
    if (uniform) attr_d(a, "hetinv:binSpacing", spacing);
    size_t size = (size_t)pl->count * 26 + 4;
    char *list = malloc(size);
    if (list != NULL && format_vector(list, size, pl->centres, pl->count) && strlen(list) <= ATTRIBUTE_MAX) {
      attr_s(a, "hetinv:binCentres", list);
    }
    free(list);
    attr_s(a, "hetinv:pathlengthMeaning", "geometric length travelled inside the medium; "
           "time of flight = pathlength * eta / c0");
  }
  /* run */
  attr_d(a, "hetinv:photons", (double)sc->photons);
  snprintf(buf, sizeof buf, "%llu", (unsigned long long)sc->seed);
  attr_s(a, "hetinv:seed", buf);
  attr_d(a, "hetinv:batches", res->batches);
  attr_d(a, "hetinv:stream", res->stream);
}

/* Writes one stack (values, errors or ballistic) of an orthographic row. */
static int write_stack(const scene_t *sc, hetinv_context_t *ctx, const render_result_t *res,
                       int row, const row_totals_t *t, stack_kind_t kind, int has_ballistic,
                       const char *path, jr_t *jr) {
  const scene_sensor_t *s = &sc->sensors[sc->rows[row].sensor];
  const scene_pathlength_t *pl = &sc->pathlengths[sc->rows[row].pathlength];
  const double *src = kind == STACK_VALUES ? res->values
                      : kind == STACK_STD_ERRORS ? res->std_errors : res->ballistic;
  const int32_t w = s->width, h = s->height;
  hetinv_image_t *img = NULL;
  hetinv_result_t r = hetinv_image_create(ctx, w, h, t->bins, &img);
  for (int32_t b = 0; r == HETINV_SUCCESS && b < t->bins; ++b) {
    char name[32];
    scene_channel_name(pl, b, name, sizeof name);
    r = hetinv_image_set_channel_name(img, b, name);
    float *px = hetinv_image_channel_data(img, b);
    const double *bin = src + t->offset + (size_t)b * (size_t)t->pixels;
    for (int32_t j = 0; r == HETINV_SUCCESS && j < h; ++j) {
      for (int32_t i = 0; i < w; ++i) px[(size_t)(h - 1 - j) * (size_t)w + (size_t)i] = (float)bin[(size_t)j * (size_t)w + (size_t)i];
    }
  }
  if (r != HETINV_SUCCESS) {
    hetinv_image_destroy(&img);
    return jr_fail(jr, path, "%s (%s)", hetinv_context_last_error_message(ctx), hetinv_result_name(r));
  }
  attrs_t a = {img, HETINV_SUCCESS, NULL};
  set_attributes(&a, sc, res, row, kind, has_ballistic);
  if (a.result != HETINV_SUCCESS) {
    jr_fail(jr, path, "attribute %s: %s (%s)", a.failed, hetinv_context_last_error_message(ctx),
            hetinv_result_name(a.result));
    hetinv_image_destroy(&img);
    return -1;
  }
  r = hetinv_image_write_exr(img, path);
  hetinv_image_destroy(&img);
  if (r != HETINV_SUCCESS) {
    return jr_fail(jr, path, "%s (%s)", hetinv_context_last_error_message(ctx), hetinv_result_name(r));
  }
  return 0;
}

/* PNG preview of the row's image summed over bins, viridis, auto range. */
static int write_preview(const scene_t *sc, hetinv_context_t *ctx, const render_result_t *res,
                         int row, const row_totals_t *t, const char *path, jr_t *jr) {
  const scene_sensor_t *s = &sc->sensors[sc->rows[row].sensor];
  const int32_t w = s->width, h = s->height;
  hetinv_image_t *img = NULL;
  hetinv_result_t r = hetinv_image_create(ctx, w, h, 1, &img);
  if (r == HETINV_SUCCESS) {
    float *px = hetinv_image_channel_data(img, 0);
    for (int32_t j = 0; j < h; ++j) {
      for (int32_t i = 0; i < w; ++i) {
        double sum = 0.0;
        for (int32_t b = 0; b < t->bins; ++b) {
          sum += res->values[t->offset + (size_t)b * (size_t)t->pixels + (size_t)j * (size_t)w + (size_t)i];
        }
        px[(size_t)(h - 1 - j) * (size_t)w + (size_t)i] = (float)sum;
      }
    }
    r = hetinv_image_write_png(img, 0, path, 0.0, 0.0, HETINV_COLORMAP_VIRIDIS);
  }
  hetinv_image_destroy(&img);
  if (r != HETINV_SUCCESS) {
    return jr_fail(jr, path, "%s (%s)", hetinv_context_last_error_message(ctx), hetinv_result_name(r));
  }
  return 0;
}

int output_write_images(const scene_t *sc, hetinv_context_t *ctx, const render_result_t *res,
                        const char *outdir, FILE *log, jr_t *jr) {
  for (int row = 0; row < sc->row_count; ++row) {
    const scene_sensor_t *s = &sc->sensors[sc->rows[row].sensor];
    if (s->kind != SENSOR_ORTHOGRAPHIC) continue;
    row_totals_t t;
    if (row_totals(sc, res, row, &t) < 0) return jr_fail(jr, "", "out of memory");
    int has_ballistic = 0;
    for (size_t k = 0; k < (size_t)t.pixels * (size_t)t.bins; ++k) has_ballistic |= res->ballistic[t.offset + k] != 0.0;
    char path[4608];
    const char *base = sc->rows[row].name;
    int status = 0;
    snprintf(path, sizeof path, "%s/%s.exr", outdir, base);
    status = write_stack(sc, ctx, res, row, &t, STACK_VALUES, has_ballistic, path, jr);
    if (status == 0) {
      snprintf(path, sizeof path, "%s/%s_stderr.exr", outdir, base);
      status = write_stack(sc, ctx, res, row, &t, STACK_STD_ERRORS, has_ballistic, path, jr);
    }
    if (status == 0 && has_ballistic) {
      snprintf(path, sizeof path, "%s/%s_ballistic.exr", outdir, base);
      status = write_stack(sc, ctx, res, row, &t, STACK_BALLISTIC, has_ballistic, path, jr);
    }
    if (status == 0) {
      snprintf(path, sizeof path, "%s/%s.png", outdir, base);
      status = write_preview(sc, ctx, res, row, &t, path, jr);
    }
    if (status == 0 && log != NULL) {
      fprintf(log, "wrote %s/%s.exr  (%d x %d pixels, %d channel%s; + _stderr.exr%s, .png)\n",
              outdir, base, (int)s->width, (int)s->height, (int)t.bins, t.bins == 1 ? "" : "s",
              has_ballistic ? ", _ballistic.exr" : "");
    }
    row_totals_free(&t);
    if (status != 0) return -1;
  }
  return 0;
}

void output_print_summary(const scene_t *sc, const render_result_t *res, FILE *log) {
  if (log == NULL) return;
  for (int row = 0; row < sc->row_count; ++row) {
    const scene_row_t *rw = &sc->rows[row];
    const scene_sensor_t *s = &sc->sensors[rw->sensor];
    row_totals_t t;
    if (row_totals(sc, res, row, &t) < 0) continue;
    if (s->kind != SENSOR_ORTHOGRAPHIC) { /* hemispherical, fiber: power */
      fprintf(log, "%s: %s <- %s: %.6g %s %.2g of the emitted power (unscattered %.6g)%s\n",
              rw->name, s->name, sc->emitters[rw->emitter].name, t.value,
              t.std_error_exact ? "+-" : "+- at most", t.std_error, t.ballistic,
              t.bins > 1 ? ", summed over the bins" : "");
    } else {
      fprintf(log, "%s: %s <- %s: %.6g per sr leaving through the sensor (ballistic %.6g)\n",
              rw->name, s->name, sc->emitters[rw->emitter].name, t.value, t.ballistic);
    }
    row_totals_free(&t);
  }
  const hetinv_render_stats_t *st = &res->stats;
  fprintf(log, "%llu photons in %.3g s on %d thread%s; per emitter: specular %.4g, absorbed %.4g "
          "+- %.2g, escaped", (unsigned long long)st->photons, st->seconds, (int)res->threads,
          res->threads == 1 ? "" : "s", st->specular, st->absorbed, st->absorbed_std_error);
  for (int f = 0; f < 6; ++f) fprintf(log, " %s %.4g", face_names[f], st->escaped[f]);
  if (st->truncated != 0.0) fprintf(log, ", truncated %.4g", st->truncated);
  fprintf(log, "\n");
  /* Power stopped by the library's default bound is in no value, so the
   * values are low by up to that much (an optically very thick, nearly
   * non-absorbing medium: crossing T mean free paths takes about T²
   * events). A bound the scene set itself is its choice. */
  if (st->truncated != 0.0 && !scene_max_scattering_given(sc)) {
    fprintf(stderr,
            "hetinv-render: warning: %llu path%s reached the default bound of %d scattering events and %s "
            "stopped, with %.4g of the emitted power per emitter that no value holds; set "
            "estimator.max_scattering higher (0: no bound) if that is not below the values' standard errors\n",
            (unsigned long long)st->truncated_paths, st->truncated_paths == 1 ? "" : "s",
            HETINV_ESTIMATOR_DEFAULT_MAX_SCATTERING, st->truncated_paths == 1 ? "was" : "were", st->truncated);
  }
}

/* array of n numbers, or NULL when out of memory */
static cJSON *numbers(const double *x, int n) { return cJSON_CreateDoubleArray(x, n); }

int output_print_totals_json(const scene_t *sc, const render_result_t *res, FILE *out) {
  cJSON *doc = cJSON_CreateObject();
  int ok = doc != NULL;
  char seed[32];
  snprintf(seed, sizeof seed, "%llu", (unsigned long long)sc->seed);
  ok = ok && cJSON_AddStringToObject(doc, "scene", sc->path) &&
       cJSON_AddNumberToObject(doc, "photons", (double)sc->photons) &&
       cJSON_AddStringToObject(doc, "seed", seed) &&
       cJSON_AddStringToObject(doc, "unit", sc->unit);
  cJSON *rows = ok ? cJSON_AddArrayToObject(doc, "rows") : NULL;
  ok = ok && rows != NULL;
  for (int row = 0; ok && row < sc->row_count; ++row) {
    const scene_row_t *rw = &sc->rows[row];
    const scene_sensor_t *s = &sc->sensors[rw->sensor];
    row_totals_t t;
    if (row_totals(sc, res, row, &t) < 0) {
      ok = 0;
      break;
    }
    cJSON *o = cJSON_CreateObject();
    ok = o != NULL && cJSON_AddItemToArray(rows, o);
    int power = s->kind != SENSOR_ORTHOGRAPHIC; /* hemispherical, fiber */
    ok = ok && cJSON_AddStringToObject(o, "name", rw->name) &&
         cJSON_AddStringToObject(o, "emitter", sc->emitters[rw->emitter].name) &&
         cJSON_AddStringToObject(o, "sensor", s->name) &&
         cJSON_AddStringToObject(o, "sensor_type", scene_sensor_type(s->kind)) &&
         cJSON_AddStringToObject(o, "pathlength", sc->pathlengths[rw->pathlength].name) &&
         cJSON_AddNumberToObject(o, "bins", t.bins) &&
         cJSON_AddStringToObject(o, "quantity",
                                 power ? "fraction of the emitted power"
                                      : "radiance integrated over the sensor area, per sr, "
                                        "per unit emitted power") &&
         cJSON_AddNumberToObject(o, "value", t.value) &&
         cJSON_AddNumberToObject(o, "std_error", t.std_error) &&
         cJSON_AddBoolToObject(o, "std_error_is_bound", !t.std_error_exact) &&
         cJSON_AddNumberToObject(o, "ballistic", t.ballistic);
    if (ok && t.bins > 1) {
      cJSON *per_bin = cJSON_AddObjectToObject(o, "per_bin");
      cJSON *a = numbers(t.bin_value, t.bins), *b = numbers(t.bin_std_error, t.bins),
            *c = numbers(t.bin_ballistic, t.bins);
      ok = per_bin != NULL && a != NULL && b != NULL && c != NULL;
      if (ok) {
        cJSON_AddItemToObject(per_bin, "value", a);
        cJSON_AddItemToObject(per_bin, "std_error", b);
        cJSON_AddItemToObject(per_bin, "ballistic", c);
      } else {
        cJSON_Delete(a);
        cJSON_Delete(b);
        cJSON_Delete(c);
      }
    }
    row_totals_free(&t);
  }
  const hetinv_render_stats_t *st = &res->stats;
  cJSON *stats = ok ? cJSON_AddObjectToObject(doc, "stats") : NULL;
  ok = ok && stats != NULL && cJSON_AddNumberToObject(stats, "photons", (double)st->photons) &&
       cJSON_AddNumberToObject(stats, "seconds", st->seconds) &&
       cJSON_AddNumberToObject(stats, "threads", res->threads) &&
       cJSON_AddNumberToObject(stats, "specular", st->specular) &&
       cJSON_AddNumberToObject(stats, "absorbed", st->absorbed) &&
       cJSON_AddNumberToObject(stats, "absorbed_std_error", st->absorbed_std_error) &&
       cJSON_AddNumberToObject(stats, "truncated", st->truncated);
  cJSON *esc = ok ? cJSON_AddObjectToObject(stats, "escaped") : NULL;
  cJSON *esc_err = esc ? cJSON_AddObjectToObject(stats, "escaped_std_error") : NULL;
  ok = ok && esc != NULL && esc_err != NULL;
  for (int f = 0; ok && f < 6; ++f) {
    ok = cJSON_AddNumberToObject(esc, face_names[f], st->escaped[f]) &&
         cJSON_AddNumberToObject(esc_err, face_names[f], st->escaped_std_error[f]);
  }
  char *text = ok ? cJSON_Print(doc) : NULL;
  int status = text != NULL ? 0 : -1;
  if (text != NULL) fprintf(out, "%s\n", text);
  cJSON_free(text);
  cJSON_Delete(doc);
  return status;
}
