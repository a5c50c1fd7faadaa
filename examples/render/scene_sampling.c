/* "emitters", "sensors" and "pathlength(s)" → hetinv sampling functions. */
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene.h"

/* Lower and upper face coordinates (u, v) of a face of the box. */
static void face_extent(const scene_t *sc, hetinv_face_t face, double lo[2], double hi[2]) {
  int u, v;
  scene_face_axes(face, &u, &v);
  lo[0] = sc->box_min[u];
  lo[1] = sc->box_min[v];
  hi[0] = sc->box_max[u];
  hi[1] = sc->box_max[v];
}

/* The 3D point of face coordinates uv on a face. */
static void face_point(const scene_t *sc, hetinv_face_t face, const double uv[2], double p[3]) {
  int u, v, a = (int)face / 2;
  scene_face_axes(face, &u, &v);
  p[a] = (face & 1) ? sc->box_max[a] : sc->box_min[a];
  p[u] = uv[0];
  p[v] = uv[1];
}

/* The face's outward normal times sign. */
static void face_normal(hetinv_face_t face, double sign, double n[3]) {
  n[0] = n[1] = n[2] = 0.0;
  n[face / 2] = ((face & 1) ? 1.0 : -1.0) * sign;
}

/* "name": a valid, unique file-name part; "<prefix><index>" by default. */
static int read_name(jr_t *jr, const cJSON *obj, const char *path, const char *prefix, int index,
                     const void *base, size_t stride, char name[SCENE_NAME_MAX]) {
  const char *given = NULL;
  char at[JR_PATH_MAX];
  jr_key(at, path, "name");
  int r = jr_string(jr, obj, path, "name", JR_OPTIONAL, &given);
  if (r < 0) return -1;
  if (r == 0) {
    snprintf(name, SCENE_NAME_MAX, "%s%d", prefix, index);
  } else {
    if (scene_check_name(jr, at, given, SCENE_NAME_MAX) < 0) return -1;
    snprintf(name, SCENE_NAME_MAX, "%s", given);
  }
  for (int i = 0; i < index; ++i) {
    if (strcmp((const char *)base + (size_t)i * stride, name) == 0) {
      return jr_fail(jr, r ? at : path, "the name \"%s\" is already taken by %.*s[%d]", name,
                     (int)strcspn(path, "["), path, i);
    }
  }
  return 0;
}

/* "rect": [[u0, v0], [u1, v1]] with u0 < u1, v0 < v1. Returns 1 if present. */
static int read_rect(jr_t *jr, const cJSON *obj, const char *path, double lo[2], double hi[2]) {
  char at[JR_PATH_MAX], buf[96];
  jr_key(at, path, "rect");
  const cJSON *rect = jr_get(obj, "rect");
  if (rect == NULL) return 0;
  int ok = cJSON_IsArray(rect) && cJSON_GetArraySize(rect) == 2;
  for (int c = 0; ok && c < 2; ++c) {
    const cJSON *corner = cJSON_GetArrayItem(rect, c);
    ok = cJSON_IsArray(corner) && cJSON_GetArraySize(corner) == 2;
    for (int k = 0; ok && k < 2; ++k) {
      const cJSON *x = cJSON_GetArrayItem(corner, k);
      ok = cJSON_IsNumber(x) && isfinite(x->valuedouble);
      if (ok) (c == 0 ? lo : hi)[k] = x->valuedouble;
    }
  }
  if (!ok) {
    return jr_fail(jr, at, "expected [[u0, v0], [u1, v1]] (two corners of 2 numbers), found %s",
                   jr_describe(rect, buf, sizeof buf));
  }
  if (!(lo[0] < hi[0] && lo[1] < hi[1])) {
    return jr_fail(jr, at, "the corners [%g, %g] and [%g, %g] make an empty rectangle; the "
                   "first must be below the second in u and in v", lo[0], lo[1], hi[0], hi[1]);
  }
  return 1;
}

/* "pattern": rows of weights, row 0 at v = rect_min[1]. */
static int read_pattern(jr_t *jr, const cJSON *obj, const char *path, int32_t *width,
                        int32_t *height, double **out) {
  const cJSON *rows = NULL;
  int h = 0;
  int r = jr_array(jr, obj, path, "pattern", JR_OPTIONAL, 1, &rows, &h);
  if (r <= 0) return r;
  char at[JR_PATH_MAX], row_at[JR_PATH_MAX], buf[96];
  jr_key(at, path, "pattern");
  const cJSON *row0 = cJSON_GetArrayItem(rows, 0);
  int w = cJSON_IsArray(row0) ? cJSON_GetArraySize(row0) : 0;
  if (w < 1) {
    jr_index(row_at, at, 0);
    return jr_fail(jr, row_at, "expected an array of weights (one row of the pattern), found %s",
                   jr_describe(row0, buf, sizeof buf));
  }
  if ((int64_t)w * h > (1 << 24)) return jr_fail(jr, at, "more than 2^24 weights");
  double *weights = malloc((size_t)w * (size_t)h * sizeof *weights);
  if (weights == NULL) return jr_fail(jr, at, "out of memory");
  int j = 0;
  const cJSON *row;
  cJSON_ArrayForEach(row, rows) {
    jr_index(row_at, at, j);
    if (!cJSON_IsArray(row) || cJSON_GetArraySize(row) != w) {
      free(weights);
      return jr_fail(jr, row_at, "expected an array of %d weights (like row 0), found %s", w,
                     jr_describe(row, buf, sizeof buf));
    }
    int i = 0;
    const cJSON *x;
    cJSON_ArrayForEach(x, row) {
      char x_at[JR_PATH_MAX];
      jr_index(x_at, row_at, i);
      double v = 0.0;
      if (jr_item_number(jr, x, x_at, &v) < 0 ||
          (v < 0.0 && jr_fail(jr, x_at, "is %g; weights must be >= 0", v) < 0)) {
        free(weights);
        return -1;
      }
      weights[(size_t)j * (size_t)w + (size_t)i++] = v;
    }
    ++j;
  }
  *width = w;
  *height = h;
  *out = weights;
  return 1;
}

static int build_emitter(scene_t *sc, jr_t *jr, const cJSON *item, const char *at,
                         scene_emitter_t *e) {
  static const char *const types[] = {"ideal", "area", "diffuse", "combination", NULL};
  static const char *const ideal_keys[] = {"name", "type", "origin", "direction", "face", "point", NULL};
  static const char *const area_keys[] = {"name", "type", "face", "direction", "rect", "pattern", NULL};
  static const char *const diffuse_keys[] = {"name", "type", "face", "point", NULL};
  static const char *const combination_keys[] = {"name", "type", "sources", NULL};
  static const char *const *const keys[] = {ideal_keys, area_keys, diffuse_keys, combination_keys};
  char buf[96];
  if (!cJSON_IsObject(item)) {
    return jr_fail(jr, at, "expected an object, found %s", jr_describe(item, buf, sizeof buf));
  }
  int type = 0, face = 0;
  if (jr_choice(jr, item, at, "type", JR_REQUIRED, types, &type) < 0 ||
      jr_check_object(jr, item, at, keys[type]) < 0 ||
      read_name(jr, item, at, "emitter", (int)(e - sc->emitters), sc->emitters, sizeof *e, e->name) < 0) {
    return -1;
  }
  e->type = types[type];
  e->json = item;
  int has_face = jr_choice(jr, item, at, "face", type == 1 || type == 2, face_names, &face);
  if (has_face < 0) return -1;
  double lo[2] = {0, 0}, hi[2] = {0, 0}, point[2] = {0, 0}, dir[3] = {0, 0, 0}, origin[3];
  if (has_face) {
    face_extent(sc, face, lo, hi);
    point[0] = 0.5 * (lo[0] + hi[0]);
    point[1] = 0.5 * (lo[1] + hi[1]);
    face_normal(face, -1.0, dir); /* default: straight in */
  }
  hetinv_result_t r = HETINV_SUCCESS;
  hetinv_context_t *ctx = hetinv_medium_context(sc->medium);
  switch (type) {
    case 0: { /* ideal: origin + direction, or face + point (+ direction) */
      int has_origin = jr_numbers(jr, item, at, "origin", JR_OPTIONAL, 3, origin);
      if (has_origin < 0) return -1;
      if (has_origin == has_face) {
        return jr_fail(jr, at, "give either \"origin\" (a point outside the box) or \"face\" "
                       "with an optional \"point\" on it%s", has_origin ? ", not both" : "");
      }
      if (has_origin && jr_get(item, "point") != NULL) {
        char key_at[JR_PATH_MAX];
        jr_key(key_at, at, "point");
        return jr_fail(jr, key_at, "only allowed with \"face\", not with \"origin\"");
      }
      if (jr_numbers(jr, item, at, "point", JR_OPTIONAL, 2, point) < 0 ||
          jr_numbers(jr, item, at, "direction", has_origin, 3, dir) < 0) {
        return -1;
      }
      if (has_face) face_point(sc, face, point, origin);
      r = hetinv_emitter_create_ideal(sc->medium, origin, dir, &e->handle);
      break;
    }
    case 1: { /* area */
      double *pattern = NULL;
      int32_t pw = 0, ph = 0;
      if (jr_numbers(jr, item, at, "direction", JR_OPTIONAL, 3, dir) < 0 ||
          read_rect(jr, item, at, lo, hi) < 0 ||
          read_pattern(jr, item, at, &pw, &ph, &pattern) < 0) {
        return -1;
      }
      r = hetinv_emitter_create_area(sc->medium, face, dir, lo, hi, pattern ? pw : 1,
                                     pattern ? ph : 1, pattern, &e->handle);
      free(pattern);
      break;
    }
    case 2: /* diffuse */
      if (jr_numbers(jr, item, at, "point", JR_OPTIONAL, 2, point) < 0) return -1;
      r = hetinv_emitter_create_diffuse(sc->medium, face, point, &e->handle);
      break;
    default: { /* combination */
      const cJSON *sources = NULL;
      int count = 0;
      if (jr_array(jr, item, at, "sources", JR_REQUIRED, 1, &sources, &count) < 0) return -1;
      double *o = malloc((size_t)count * 7 * sizeof *o);
      if (o == NULL) return jr_fail(jr, at, "out of memory");
      double *d = o + 3 * (size_t)count, *w = o + 6 * (size_t)count;
      static const char *const source_keys[] = {"origin", "direction", "weight", NULL};
      char src_at[JR_PATH_MAX], list_at[JR_PATH_MAX];
      jr_key(list_at, at, "sources");
      int i = 0;
      const cJSON *s;
      cJSON_ArrayForEach(s, sources) {
        jr_index(src_at, list_at, i);
        w[i] = 1.0;
        if (jr_check_object(jr, s, src_at, source_keys) < 0 ||
            jr_numbers(jr, s, src_at, "origin", JR_REQUIRED, 3, o + 3 * i) < 0 ||
            jr_numbers(jr, s, src_at, "direction", JR_REQUIRED, 3, d + 3 * i) < 0 ||
            jr_number(jr, s, src_at, "weight", JR_OPTIONAL, w + i) < 0) {
          free(o);
          return -1;
        }
        ++i;
      }
      r = hetinv_emitter_create_combination(sc->medium, count, o, d, w, &e->handle);
      free(o);
      break;
    }
  }
  if (r != HETINV_SUCCESS) return scene_lib_fail(jr, at, ctx, r);
  return 0;
}

int scene_build_emitters(scene_t *sc, jr_t *jr) {
  const cJSON *list = NULL;
  int count = 0;
  if (jr_array(jr, sc->root, "", "emitters", JR_REQUIRED, 1, &list, &count) < 0) return -1;
  sc->emitters = calloc((size_t)count, sizeof *sc->emitters);
  if (sc->emitters == NULL) return jr_fail(jr, "emitters", "out of memory");
  const cJSON *item;
  cJSON_ArrayForEach(item, list) {
    char at[JR_PATH_MAX];
    jr_index(at, "emitters", sc->emitter_count);
    scene_emitter_t *e = &sc->emitters[sc->emitter_count++];
    if (build_emitter(sc, jr, item, at, e) < 0) return -1;
  }
  return 0;
}

/* Orthographic pixel grid: origin (default the face's lower corner), and
 * any of width/height and pixel_size; the missing ones cover the face. */
static int orthographic_grid(scene_t *sc, jr_t *jr, const cJSON *item, const char *at,
                             scene_sensor_t *s) {
  double lo[2], hi[2];
  face_extent(sc, s->face, lo, hi);
  s->origin[0] = lo[0];
  s->origin[1] = lo[1];
  int64_t w = 0, h = 0;
  int has_origin = jr_numbers(jr, item, at, "origin", JR_OPTIONAL, 2, s->origin);
  int has_size = jr_numbers(jr, item, at, "pixel_size", JR_OPTIONAL, 2, s->pixel_size);
  int has_w = has_origin < 0 || has_size < 0 ? -1 : jr_integer(jr, item, at, "width", JR_OPTIONAL, 1, 65536, &w);
  int has_h = has_w < 0 ? -1 : jr_integer(jr, item, at, "height", JR_OPTIONAL, 1, 65536, &h);
  if (has_h < 0) return -1;
  if (has_w != has_h) {
    char key_at[JR_PATH_MAX];
    jr_key(key_at, at, has_w ? "height" : "width");
    return jr_fail(jr, key_at, "missing: give \"width\" and \"height\" together");
  }
  double extent[2];
  for (int k = 0; k < 2; ++k) {
    extent[k] = hi[k] - s->origin[k];
    if (has_size && !(s->pixel_size[k] > 0.0)) {
      char key_at[JR_PATH_MAX], idx_at[JR_PATH_MAX];
      jr_key(key_at, at, "pixel_size");
      jr_index(idx_at, key_at, k);
      return jr_fail(jr, idx_at, "is %g; it must be > 0", s->pixel_size[k]);
    }
    if (!has_size || !has_w) {
      if (!(extent[k] > 0.0)) {
        char key_at[JR_PATH_MAX];
        jr_key(key_at, at, "origin");
        return jr_fail(jr, key_at, "[%g, %g] leaves nothing of the face to cover; give "
                       "\"width\", \"height\" and \"pixel_size\"", s->origin[0], s->origin[1]);
      }
    }
  }
  if (has_w && !has_size) {
    s->pixel_size[0] = extent[0] / (double)w;
    s->pixel_size[1] = extent[1] / (double)h;
  } else if (!has_w) {
    if (!has_size) { /* square pixels, 64 along the longer side */
      s->pixel_size[0] = s->pixel_size[1] = fmax(extent[0], extent[1]) / 64.0;
    }
    double n[2];
    for (int k = 0; k < 2; ++k) {
      n[k] = ceil(extent[k] / s->pixel_size[k] - 1e-9);
      if (n[k] > 65536.0) {
        char key_at[JR_PATH_MAX];
        jr_key(key_at, at, "pixel_size");
        return jr_fail(jr, key_at, "gives %.0f pixels across the face; at most 65536", n[k]);
      }
    }
    w = (int64_t)fmax(1.0, n[0]);
    h = (int64_t)fmax(1.0, n[1]);
  }
  s->width = (int32_t)w;
  s->height = (int32_t)h;
  if ((int64_t)w * h > HETINV_MAX_SENSOR_PIXELS) {
    return jr_fail(jr, at, "%lld x %lld pixels; at most %ld in all (HETINV_MAX_SENSOR_PIXELS)",
                   (long long)w, (long long)h, (long)HETINV_MAX_SENSOR_PIXELS);
  }
  return 0;
}

/* The "type" of each kind, in the order of scene_sensor_kind_t. */
static const char *const sensor_types[] = {"orthographic", "hemispherical", "fiber", NULL};

const char *scene_sensor_type(scene_sensor_kind_t kind) { return sensor_types[kind]; }

static int build_sensor(scene_t *sc, jr_t *jr, const cJSON *item, const char *at,
                        scene_sensor_t *s) {
  static const char *const ortho_keys[] = {"name", "type", "face", "direction", "origin",
                                           "pixel_size", "width", "height", NULL};
  static const char *const hemi_keys[] = {"name", "type", "face", "rect", NULL};
  static const char *const fiber_keys[] = {"name", "type", "face", "centre", "radius", "numerical_aperture", NULL};
  static const char *const *const keys[] = {ortho_keys, hemi_keys, fiber_keys};
  char buf[96];
  if (!cJSON_IsObject(item)) {
    return jr_fail(jr, at, "expected an object, found %s", jr_describe(item, buf, sizeof buf));
  }
  int type = 0, face = 0;
  if (jr_choice(jr, item, at, "type", JR_REQUIRED, sensor_types, &type) < 0 ||
      jr_check_object(jr, item, at, keys[type]) < 0 ||
      read_name(jr, item, at, "sensor", (int)(s - sc->sensors), sc->sensors, sizeof *s, s->name) < 0 ||
      jr_choice(jr, item, at, "face", JR_REQUIRED, face_names, &face) < 0) {
    return -1;
  }
  s->kind = (scene_sensor_kind_t)type;
  s->face = face;
  s->json = item;
  hetinv_context_t *ctx = hetinv_medium_context(sc->medium);
  hetinv_result_t r;
  if (s->kind == SENSOR_ORTHOGRAPHIC) {
    face_normal(face, 1.0, s->direction); /* default: straight out */
    if (jr_numbers(jr, item, at, "direction", JR_OPTIONAL, 3, s->direction) < 0 ||
        orthographic_grid(sc, jr, item, at, s) < 0) {
      return -1;
    }
    r = hetinv_sensor_create_orthographic(sc->medium, face, s->direction, s->origin,
                                          s->pixel_size, s->width, s->height, &s->handle);
  } else if (s->kind == SENSOR_FIBER) {
    s->width = s->height = 1;
    /* Every field required: a default centre, core or NA would hide a typo. */
    if (jr_numbers(jr, item, at, "centre", JR_REQUIRED, 2, s->centre) < 0 ||
        jr_positive(jr, item, at, "radius", JR_REQUIRED, &s->radius) < 0 ||
        jr_positive(jr, item, at, "numerical_aperture", JR_REQUIRED, &s->numerical_aperture) < 0) {
      return -1;
    }
    r = hetinv_sensor_create_fiber(sc->medium, face, s->centre, s->radius, s->numerical_aperture, &s->handle);
  } else {
    s->width = s->height = 1;
    s->has_rect = read_rect(jr, item, at, s->rect_min, s->rect_max);
    if (s->has_rect < 0) return -1;
    r = hetinv_sensor_create_hemispherical(sc->medium, face, s->has_rect ? s->rect_min : NULL,
                                           s->has_rect ? s->rect_max : NULL, &s->handle);
  }
  if (r != HETINV_SUCCESS) return scene_lib_fail(jr, at, ctx, r);
  return 0;
}

int scene_build_sensors(scene_t *sc, jr_t *jr) {
  const cJSON *list = NULL;
  int count = 0;
  if (jr_array(jr, sc->root, "", "sensors", JR_REQUIRED, 1, &list, &count) < 0) return -1;
  sc->sensors = calloc((size_t)count, sizeof *sc->sensors);
  if (sc->sensors == NULL) return jr_fail(jr, "sensors", "out of memory");
  const cJSON *item;
  cJSON_ArrayForEach(item, list) {
    char at[JR_PATH_MAX];
    jr_index(at, "sensors", sc->sensor_count);
    scene_sensor_t *s = &sc->sensors[sc->sensor_count++];
    if (build_sensor(sc, jr, item, at, s) < 0) return -1;
  }
  return 0;
}

/* Millimetres per length unit, for an IRF's time axis: 0 when the unit is
 * not one the conversion knows (then offsets must be given in the unit). */
static double unit_mm(const char *unit) {
  static const struct { const char *name; double mm; } units[] = {
      {"mm", 1.0}, {"cm", 10.0}, {"m", 1000.0}, {"um", 1e-3}, {"\u00b5m", 1e-3}, {"\u03bcm", 1e-3}};
  for (size_t i = 0; i < sizeof units / sizeof units[0]; ++i) {
    if (strcmp(unit, units[i].name) == 0) return units[i].mm;
  }
  return 0.0;
}

/* A number array key of an IRF: count values into *out (malloc'd). */
static int read_irf_array(jr_t *jr, const cJSON *irf, const char *irf_at, const char *key,
                          int *count, double **out) {
  const cJSON *arr = NULL;
  char at[JR_PATH_MAX];
  jr_key(at, irf_at, key);
  if (jr_array(jr, irf, irf_at, key, JR_REQUIRED, 1, &arr, count) < 0) return -1;
  if (*count > HETINV_MAX_IRF_SAMPLES) {
    return jr_fail(jr, at, "%d samples; at most %d (HETINV_MAX_IRF_SAMPLES)", *count,
                   HETINV_MAX_IRF_SAMPLES);
  }
  *out = malloc((size_t)*count * sizeof **out);
  if (*out == NULL) return jr_fail(jr, at, "out of memory");
  int i = 0;
  const cJSON *e;
  cJSON_ArrayForEach(e, arr) {
    char e_at[JR_PATH_MAX];
    jr_index(e_at, at, i);
    if (jr_item_number(jr, e, e_at, &(*out)[i]) < 0) return -1;
    ++i;
  }
  return 0;
}

/* "irf": {"samples": [h...], "times_ps": [t...]} or {"samples": [...],
 * "offsets": [d...]}: an instrument response convolved with the bins
 * (hetinv_pathlength_create_bins_irf). Times are converted with the
 * medium's η (τ = c₀ t / η) and the scene's unit. */
static int read_irf(scene_t *sc, jr_t *jr, const cJSON *item, const char *at,
                    scene_pathlength_t *pl) {
  const cJSON *irf = NULL;
  char irf_at[JR_PATH_MAX], key_at[JR_PATH_MAX];
  jr_key(irf_at, at, "irf");
  int got = jr_object(jr, item, at, "irf", JR_OPTIONAL, &irf);
  if (got <= 0) return got;
  static const char *const allowed[] = {"samples", "times_ps", "offsets", NULL};
  if (jr_check_object(jr, irf, irf_at, allowed) < 0) return -1;
  const bool times = jr_get(irf, "times_ps") != NULL, offsets = jr_get(irf, "offsets") != NULL;
  if (times == offsets) {
    return jr_fail(jr, irf_at, "give the samples' axis as \"times_ps\" (picoseconds) or "
                   "\"offsets\" (pathlength in the scene's unit), %s", times ? "not both" : "one of them");
  }
  int n_samples = 0, n_axis = 0;
  if (read_irf_array(jr, irf, irf_at, "samples", &n_samples, &pl->irf_samples) < 0 ||
      read_irf_array(jr, irf, irf_at, times ? "times_ps" : "offsets", &n_axis, &pl->irf_offsets) < 0) {
    return -1;
  }
  jr_key(key_at, irf_at, times ? "times_ps" : "offsets");
  if (n_axis != n_samples) {
    return jr_fail(jr, key_at, "has %d element%s but \"samples\" has %d; one %s per sample",
                   n_axis, n_axis == 1 ? "" : "s", n_samples, times ? "time" : "offset");
  }
  double sum = 0.0;
  for (int i = 0; i < n_samples; ++i) {
    if (pl->irf_samples[i] < 0.0) {
      jr_key(key_at, irf_at, "samples");
      char e_at[JR_PATH_MAX];
      jr_index(e_at, key_at, i);
      return jr_fail(jr, e_at, "is %g; samples are >= 0 (clip a background-subtracted IRF at 0)",
                     pl->irf_samples[i]);
    }
    sum += pl->irf_samples[i];
  }
  if (!(sum > 0.0) || !isfinite(sum)) {
    jr_key(key_at, irf_at, "samples");
    return jr_fail(jr, key_at, "add up to %g; expected a finite sum > 0", sum);
  }
  if (times) {
    double mm = unit_mm(sc->unit);
    if (mm == 0.0) {
      return jr_fail(jr, key_at, "the scene's unit \"%s\" is none of mm, cm, m, um, so times "
                     "cannot be converted; give \"offsets\" in the unit instead", sc->unit);
    }
    hetinv_result_t r = hetinv_irf_offsets_from_times(pl->irf_offsets, (size_t)n_axis, sc->eta, mm,
                                                      pl->irf_offsets);
    if (r != HETINV_SUCCESS) {
      return jr_fail(jr, key_at, "cannot be converted with eta = %g (%s): the conversion "
                     "tau = c0 t / eta needs eta >= 1 and finite results", sc->eta, hetinv_result_name(r));
    }
  }
  pl->irf_count = n_samples;
  return 1;
}

static int build_pathlength(scene_t *sc, hetinv_context_t *ctx, jr_t *jr, const cJSON *item,
                            const char *at, int index, const char *default_name, int numbered,
                            scene_pathlength_t *pl) {
  static const char *const types[] = {"steady", "bins", NULL};
  static const char *const windows[] = {"box", "gaussian", NULL};
  static const char *const steady_keys[] = {"name", "type", NULL};
  static const char *const bins_keys[] = {"name", "type", "window", "width", "start", "spacing",
                                          "count", "centres", "irf", NULL};
  char buf[96];
  if (!cJSON_IsObject(item)) {
    return jr_fail(jr, at, "expected an object, found %s", jr_describe(item, buf, sizeof buf));
  }
  int type = 0, window = 0;
  if (jr_choice(jr, item, at, "type", JR_REQUIRED, types, &type) < 0 ||
      jr_check_object(jr, item, at, type == 0 ? steady_keys : bins_keys) < 0 ||
      read_name(jr, item, at, default_name, index, sc->pathlengths, sizeof *pl, pl->name) < 0) {
    return -1;
  }
  if (!numbered && jr_get(item, "name") == NULL) snprintf(pl->name, sizeof pl->name, "%s", default_name);
  pl->json = item;
  hetinv_result_t r;
  if (type == 0) {
    pl->steady = 1;
    pl->count = 1;
    r = hetinv_pathlength_create_steady(ctx, &pl->handle);
  } else {
    if (jr_choice(jr, item, at, "window", JR_OPTIONAL, windows, &window) < 0 ||
        jr_positive(jr, item, at, "width", JR_REQUIRED, &pl->width) < 0) {
      return -1;
    }
    pl->window = window == 0 ? HETINV_WINDOW_BOX : HETINV_WINDOW_GAUSSIAN;
    const cJSON *centres = jr_get(item, "centres");
    char key_at[JR_PATH_MAX];
    if (centres != NULL) {
      static const char *const excluded[] = {"count", "start", "spacing"};
      for (int k = 0; k < 3; ++k) {
        if (jr_get(item, excluded[k]) != NULL) {
          jr_key(key_at, at, excluded[k]);
          return jr_fail(jr, key_at, "not allowed together with \"centres\"");
        }
      }
      int count = 0;
      if (jr_array(jr, item, at, "centres", JR_REQUIRED, 1, &centres, &count) < 0) return -1;
      jr_key(key_at, at, "centres");
      if (count > 32767) return jr_fail(jr, key_at, "%d bins; at most 32767", count);
      pl->centres = malloc((size_t)count * sizeof *pl->centres);
      if (pl->centres == NULL) return jr_fail(jr, key_at, "out of memory");
      int i = 0;
      const cJSON *c;
      cJSON_ArrayForEach(c, centres) {
        char c_at[JR_PATH_MAX];
        jr_index(c_at, key_at, i);
        if (jr_item_number(jr, c, c_at, &pl->centres[i]) < 0) return -1;
        if (pl->centres[i] < 0.0) {
          return jr_fail(jr, c_at, "is %g; pathlengths are >= 0", pl->centres[i]);
        }
        ++i;
      }
      pl->count = count;
    } else {
      int64_t count = 0;
      double start = 0.0, spacing = pl->width;
      if (jr_integer(jr, item, at, "count", JR_REQUIRED, 1, 32767, &count) < 0 ||
          jr_number(jr, item, at, "start", JR_OPTIONAL, &start) < 0 ||
          jr_positive(jr, item, at, "spacing", JR_OPTIONAL, &spacing) < 0) {
        return -1;
      }
      if (start < 0.0) {
        jr_key(key_at, at, "start");
        return jr_fail(jr, key_at, "is %g; pathlengths are >= 0", start);
      }
      pl->count = (int32_t)count;
      pl->centres = malloc((size_t)count * sizeof *pl->centres);
      if (pl->centres == NULL) return jr_fail(jr, at, "out of memory");
      for (int32_t i = 0; i < pl->count; ++i) pl->centres[i] = start + (i + 0.5) * spacing;
    }
    if (read_irf(sc, jr, item, at, pl) < 0) return -1;
    if (pl->irf_count > 0) {
      char irf_at[JR_PATH_MAX];
      jr_key(irf_at, at, "irf");
      r = hetinv_pathlength_create_bins_irf(ctx, pl->window, pl->count, pl->centres, pl->width,
                                            pl->irf_count, pl->irf_offsets, pl->irf_samples,
                                            &pl->handle);
      if (r != HETINV_SUCCESS) return scene_lib_fail(jr, irf_at, ctx, r);
    } else {
      r = hetinv_pathlength_create_bins(ctx, pl->window, pl->count, pl->centres, pl->width,
                                        &pl->handle);
    }
  }
  if (r != HETINV_SUCCESS) return scene_lib_fail(jr, at, ctx, r);
  return 0;
}

int scene_build_pathlengths(scene_t *sc, hetinv_context_t *ctx, jr_t *jr) {
  const cJSON *single = jr_get(sc->root, "pathlength"), *list = jr_get(sc->root, "pathlengths");
  if (single != NULL && list != NULL) {
    return jr_fail(jr, "pathlengths", "give \"pathlength\" (one) or \"pathlengths\" (a list), not both");
  }
  int count = 1;
  if (list != NULL && jr_array(jr, sc->root, "", "pathlengths", JR_REQUIRED, 1, &list, &count) < 0) {
    return -1;
  }
  sc->pathlengths = calloc((size_t)count, sizeof *sc->pathlengths);
  if (sc->pathlengths == NULL) return jr_fail(jr, "pathlengths", "out of memory");
  if (list == NULL && single == NULL) { /* steady state */
    scene_pathlength_t *pl = &sc->pathlengths[sc->pathlength_count++];
    snprintf(pl->name, sizeof pl->name, "steady");
    pl->steady = 1;
    pl->count = 1;
    hetinv_result_t r = hetinv_pathlength_create_steady(ctx, &pl->handle);
    return r == HETINV_SUCCESS ? 0 : scene_lib_fail(jr, "pathlength", ctx, r);
  }
  if (single != NULL) {
    sc->pathlength_count = 1;
    return build_pathlength(sc, ctx, jr, single, "pathlength", 0, "pathlength", 0,
                            sc->pathlengths);
  }
  const cJSON *item;
  cJSON_ArrayForEach(item, list) {
    char at[JR_PATH_MAX];
    int i = sc->pathlength_count++;
    jr_index(at, "pathlengths", i);
    if (build_pathlength(sc, ctx, jr, item, at, i, "pathlength", 1, &sc->pathlengths[i]) < 0) return -1;
  }
  return 0;
}
