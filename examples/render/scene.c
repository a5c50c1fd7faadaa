/* Scene file → run settings, measurement rows and the measurement set. The
 * medium and the sampling functions are in scene_medium.c and
 * scene_sampling.c. */
#include "scene.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The members of "estimator" and the parameters they set (photons is top-level). */
static const struct {
  const char *key;
  hetinv_estimator_param_t param;
} estimator_keys[SCENE_ESTIMATOR_KEYS] = {
    {"batches", HETINV_ESTIMATOR_BATCHES},
    {"roulette_weight", HETINV_ESTIMATOR_ROULETTE_WEIGHT},
    {"roulette_survival", HETINV_ESTIMATOR_ROULETTE_SURVIVAL},
    {"min_scattering", HETINV_ESTIMATOR_MIN_SCATTERING},
    {"max_scattering", HETINV_ESTIMATOR_MAX_SCATTERING},
    {"stream", HETINV_ESTIMATOR_STREAM}};

bool scene_max_scattering_given(const scene_t *sc) {
  for (int k = 0; k < SCENE_ESTIMATOR_KEYS; ++k) {
    if (estimator_keys[k].param == HETINV_ESTIMATOR_MAX_SCATTERING) return sc->estimator_given[k] != 0;
  }
  return false;
}

int scene_lib_fail(jr_t *jr, const char *path, const hetinv_context_t *ctx, hetinv_result_t r) {
  return jr_fail(jr, path, "%s (%s)", hetinv_context_last_error_message(ctx), hetinv_result_name(r));
}

void scene_face_axes(hetinv_face_t face, int *u, int *v) {
  int a = (int)face / 2;
  *u = a == 0 ? 1 : 0;
  *v = a == 2 ? 1 : 2;
}

/* "noise": the camera that records the render (camera.h). The library
 * checks the model again when it applies it; read here so that a bad
 * value is named before the render runs. */
static int read_noise(scene_t *sc, jr_t *jr) {
  const cJSON *o = NULL;
  int r = jr_object(jr, sc->root, "", "noise", JR_OPTIONAL, &o);
  if (r <= 0) return r;
  static const char *const allowed[] = {"full_well", "read_noise", "exposure", "auto_level", "seed", NULL};
  if (jr_check_object(jr, o, "noise", allowed) < 0) return -1;
  hetinv_noise_model_t *m = &sc->noise;
  hetinv_noise_model_default(m);
  if (jr_positive(jr, o, "noise", "full_well", JR_OPTIONAL, &m->full_well) < 0) return -1;
  if (!(m->full_well <= HETINV_NOISE_FULL_WELL_MAX)) {
    return jr_fail(jr, "noise.full_well", "is %g; expected at most %g electrons", m->full_well,
                   HETINV_NOISE_FULL_WELL_MAX);
  }
  if (jr_number(jr, o, "noise", "read_noise", JR_OPTIONAL, &m->read_noise) < 0) return -1;
  if (!(m->read_noise >= 0.0 && isfinite(m->read_noise))) {
    return jr_fail(jr, "noise.read_noise", "is %g; expected a finite number of electrons >= 0", m->read_noise);
  }
  if (jr_number(jr, o, "noise", "exposure", JR_OPTIONAL, &m->exposure) < 0) return -1;
  if (!(m->exposure >= 0.0 && isfinite(m->exposure))) {
    return jr_fail(jr, "noise.exposure", "is %g; expected electrons per unit of value > 0, or 0 for automatic",
                   m->exposure);
  }
  if (jr_number(jr, o, "noise", "auto_level", JR_OPTIONAL, &m->auto_level) < 0) return -1;
  if (!(m->auto_level > 0.0 && m->auto_level <= 1.0)) {
    return jr_fail(jr, "noise.auto_level", "is %g; expected a fraction of the full well in (0, 1]", m->auto_level);
  }
  int64_t seed = 0;
  if (jr_integer(jr, o, "noise", "seed", JR_OPTIONAL, 0, JR_INTEGER_MAX, &seed) < 0) return -1;
  m->seed = (uint64_t)seed;
  sc->has_noise = 1;
  return 0;
}

static int read_run_settings(scene_t *sc, jr_t *jr) {
  const cJSON *root = sc->root;
  int64_t v = 0;
  sc->photons = 100000;
  int r = jr_integer(jr, root, "", "photons", JR_OPTIONAL, 1, JR_INTEGER_MAX, &sc->photons);
  if (r < 0) return r;
  if ((r = jr_integer(jr, root, "", "seed", JR_OPTIONAL, 0, JR_INTEGER_MAX, &v)) < 0) return r;
  sc->seed = (uint64_t)v;
  v = 0;
  if ((r = jr_integer(jr, root, "", "threads", JR_OPTIONAL, 0, HETINV_MAX_THREADS, &v)) < 0) return r;
  sc->threads = (int32_t)v;

  if (read_noise(sc, jr) < 0) return -1;

  const cJSON *est = NULL;
  if ((r = jr_object(jr, root, "", "estimator", JR_OPTIONAL, &est)) < 0) return r;
  if (est != NULL) {
    static const char *const allowed[] = {"batches", "roulette_weight", "roulette_survival",
                                          "min_scattering", "max_scattering", "stream", NULL};
    if (jr_check_object(jr, est, "estimator", allowed) < 0) return -1;
    for (int k = 0; k < SCENE_ESTIMATOR_KEYS; ++k) {
      r = jr_number(jr, est, "estimator", estimator_keys[k].key, JR_OPTIONAL, &sc->estimator_value[k]);
      if (r < 0) return r;
      sc->estimator_given[k] = r;
    }
  }
  return 0;
}

/* Everything of scene_load but reading the file. */
static void scene_begin(scene_t *sc, const char *path, jr_t *jr) {
  memset(sc, 0, sizeof *sc);
  sc->path = path;
  jr->file = path;
  const char *slash = strrchr(path, '/');
  if (slash == NULL) {
    snprintf(sc->dir, sizeof sc->dir, ".");
  } else {
    snprintf(sc->dir, sizeof sc->dir, "%.*s", (int)(slash - path == 0 ? 1 : slash - path), path);
  }
}

static int scene_parse(scene_t *sc, jr_t *jr);

int scene_load(scene_t *sc, const char *path, jr_t *jr) {
  scene_begin(sc, path, jr);
  if (jr_load(jr, path, &sc->text, &sc->root) < 0) return -1;
  return scene_parse(sc, jr);
}

int scene_load_text(scene_t *sc, const char *path, char *text, jr_t *jr) {
  scene_begin(sc, path, jr);
  sc->text = text;
  if (jr_parse(jr, text, &sc->root) < 0) return -1;
  return scene_parse(sc, jr);
}

static int scene_parse(scene_t *sc, jr_t *jr) {
  static const char *const allowed[] = {
      "description", "unit", "box", "eta", "eta_out", "medium", "emitters", "sensors",
      "pathlength", "pathlengths", "measurements", "photons", "seed", "threads", "estimator", "noise", NULL};
  if (jr_check_object(jr, sc->root, "", allowed) < 0) return -1;
  const char *s = NULL;
  if (jr_string(jr, sc->root, "", "description", JR_OPTIONAL, &s) < 0) return -1;
  s = "mm";
  if (jr_string(jr, sc->root, "", "unit", JR_OPTIONAL, &s) < 0) return -1;
  if (strlen(s) >= sizeof sc->unit) return jr_fail(jr, "unit", "longer than %zu bytes", sizeof sc->unit - 1);
  snprintf(sc->unit, sizeof sc->unit, "%s", s);
  return read_run_settings(sc, jr);
}

/* Index of the element of an array of structs (each beginning with its
 * name) whose name is name, or -1. */
static int find_name(const void *base, size_t stride, int count, const char *name) {
  for (int i = 0; i < count; ++i) {
    if (strcmp((const char *)base + (size_t)i * stride, name) == 0) return i;
  }
  return -1;
}

/* measurements[i].<key>: a name or an index of one of count things; -2 when absent. */
static int resolve(jr_t *jr, const cJSON *item, const char *path, const char *key,
                   const char *what, const void *base, size_t stride, int count, int *out) {
  char at[JR_PATH_MAX], buf[96];
  jr_key(at, path, key);
  const cJSON *ref = jr_get(item, key);
  if (ref == NULL) {
    *out = -2;
    return 0;
  }
  if (cJSON_IsString(ref)) {
    *out = find_name(base, stride, count, ref->valuestring);
    if (*out < 0) return jr_fail(jr, at, "no %s is named \"%s\"", what, ref->valuestring);
    return 1;
  }
  if (cJSON_IsNumber(ref) && ref->valuedouble == floor(ref->valuedouble)) {
    if (!(ref->valuedouble >= 0.0 && ref->valuedouble < count)) {
      return jr_fail(jr, at, "%s index %g is out of range (the scene has %d)", what,
                     ref->valuedouble, count);
    }
    *out = (int)ref->valuedouble;
    return 1;
  }
  return jr_fail(jr, at, "expected the name or index of %s %s, found %s",
                 what[0] == 'e' ? "an" : "a", what, jr_describe(ref, buf, sizeof buf));
}

static int add_row(jr_t *jr, scene_t *sc, int *capacity, int e, int s, int p, const char *name) {
  if (sc->row_count == *capacity) {
    int cap = *capacity ? 2 * *capacity : 16;
    scene_row_t *rows = realloc(sc->rows, (size_t)cap * sizeof *rows);
    if (rows == NULL) return jr_fail(jr, "measurements", "out of memory");
    sc->rows = rows;
    *capacity = cap;
  }
  scene_row_t *row = &sc->rows[sc->row_count++];
  memset(row, 0, sizeof *row);
  row->emitter = e;
  row->sensor = s;
  row->pathlength = p;
  if (name != NULL) snprintf(row->name, sizeof row->name, "%s", name);
  return 0;
}

int scene_check_name(jr_t *jr, const char *path, const char *name, size_t max) {
  int ok = name[0] != '\0' && name[0] != '.' && strlen(name) < max;
  for (const char *c = name; ok && *c; ++c) {
    ok = (*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') ||
         *c == '_' || *c == '-' || *c == '.';
  }
  if (ok) return 0;
  return jr_fail(jr, path, "\"%s\" is not a file name of letters, digits, '_', '-' and '.' "
                 "(not starting with '.', under %zu bytes)", name, max);
}

/* A row writes <name>.exr, <name>_stderr.exr, <name>_ballistic.exr and
 * <name>.png (output.c): two rows share a file when their names are equal
 * or one is the other's plus one of those suffixes. Returns the longer
 * name, whose .exr both would write, or NULL. */
static const char *shared_file(const char *a, const char *b) {
  static const char *const suffixes[] = {"", "_stderr", "_ballistic"};
  size_t la = strlen(a), lb = strlen(b);
  const char *longer = la > lb ? a : b, *shorter = la > lb ? b : a;
  size_t ls = la > lb ? lb : la;
  if (strncmp(longer, shorter, ls) != 0) return NULL;
  for (size_t i = 0; i < sizeof suffixes / sizeof suffixes[0]; ++i) {
    if (strcmp(longer + ls, suffixes[i]) == 0) return longer;
  }
  return NULL;
}

/* The rows: "measurements", or every emitter × every sensor. */
static int build_rows(scene_t *sc, jr_t *jr) {
  const cJSON *list = NULL;
  int count = 0, capacity = 0;
  if (jr_array(jr, sc->root, "", "measurements", JR_OPTIONAL, 1, &list, &count) < 0) return -1;
  int *origin = NULL; /* measurements[] entry of each row, for messages */
  if (list == NULL) {
    if (sc->pathlength_count != 1) {
      return jr_fail(jr, "measurements", "missing: the scene has %d pathlengths, so say which "
                     "one each measurement uses", sc->pathlength_count);
    }
    for (int s = 0; s < sc->sensor_count; ++s) {
      for (int e = 0; e < sc->emitter_count; ++e) {
        if (add_row(jr, sc, &capacity, e, s, 0, NULL) < 0) return -1;
      }
    }
  } else {
    static const char *const allowed[] = {"emitter", "sensor", "pathlength", "name", NULL};
    int i = 0;
    const cJSON *item;
    cJSON_ArrayForEach(item, list) {
      char at[JR_PATH_MAX];
      jr_index(at, "measurements", i);
      if (jr_check_object(jr, item, at, allowed) < 0) goto fail;
      int e = -2, s = -2, p = -2;
      if (resolve(jr, item, at, "emitter", "emitter", sc->emitters, sizeof *sc->emitters,
                  sc->emitter_count, &e) < 0 ||
          resolve(jr, item, at, "sensor", "sensor", sc->sensors, sizeof *sc->sensors,
                  sc->sensor_count, &s) < 0 ||
          resolve(jr, item, at, "pathlength", "pathlength", sc->pathlengths,
                  sizeof *sc->pathlengths, sc->pathlength_count, &p) < 0) {
        goto fail;
      }
      if (p == -2) {
        if (sc->pathlength_count != 1) {
          jr_fail(jr, at, "no \"pathlength\": the scene has %d, so say which one",
                  sc->pathlength_count);
          goto fail;
        }
        p = 0;
      }
      const char *name = NULL;
      if (jr_string(jr, item, at, "name", JR_OPTIONAL, &name) < 0) goto fail;
      if (name != NULL && (e == -2 || s == -2)) {
        char nat[JR_PATH_MAX];
        jr_key(nat, at, "name");
        jr_fail(jr, nat, "a name needs a single emitter and a single sensor");
        goto fail;
      }
      if (name != NULL) {
        char nat[JR_PATH_MAX];
        jr_key(nat, at, "name");
        if (scene_check_name(jr, nat, name, 2 * SCENE_NAME_MAX) < 0) goto fail;
      }
      for (int s1 = s == -2 ? 0 : s; s1 < (s == -2 ? sc->sensor_count : s + 1); ++s1) {
        for (int e1 = e == -2 ? 0 : e; e1 < (e == -2 ? sc->emitter_count : e + 1); ++e1) {
          if (add_row(jr, sc, &capacity, e1, s1, p, name) < 0) goto fail;
          int *o = realloc(origin, (size_t)sc->row_count * sizeof *o);
          if (o == NULL) {
            jr_fail(jr, "measurements", "out of memory");
            goto fail;
          }
          origin = o;
          origin[sc->row_count - 1] = i;
        }
      }
      ++i;
    }
  }
  if (sc->row_count == 0) return jr_fail(jr, "measurements", "no rows to render");

  /* Default names: <sensor>_<emitter>, plus _<pathlength> where that repeats. */
  for (int r = 0; r < sc->row_count; ++r) {
    scene_row_t *row = &sc->rows[r];
    if (row->name[0] != '\0') continue;
    int repeated = 0;
    for (int q = 0; q < sc->row_count; ++q) {
      repeated |= q != r && sc->rows[q].sensor == row->sensor && sc->rows[q].emitter == row->emitter;
    }
    snprintf(row->name, sizeof row->name, "%s_%s%s%s", sc->sensors[row->sensor].name,
             sc->emitters[row->emitter].name, repeated ? "_" : "",
             repeated ? sc->pathlengths[row->pathlength].name : "");
  }
  for (int r = 0; r < sc->row_count; ++r) {
    for (int q = 0; q < r; ++q) {
      const char *file = shared_file(sc->rows[q].name, sc->rows[r].name);
      if (file != NULL) {
        char at[JR_PATH_MAX] = "measurements";
        if (origin != NULL) jr_index(at, "measurements", origin[r]);
        jr_fail(jr, at, "rows \"%s\" and \"%s\" would both write \"%s.exr\"; give them other names",
                sc->rows[q].name, sc->rows[r].name, file);
        goto fail;
      }
    }
  }
  free(origin);
  return 0;
fail:
  free(origin);
  return -1;
}

int scene_build(scene_t *sc, hetinv_context_t *ctx, jr_t *jr) {
  if (scene_build_medium(sc, ctx, jr) < 0 || scene_build_emitters(sc, jr) < 0 ||
      scene_build_sensors(sc, jr) < 0 || scene_build_pathlengths(sc, ctx, jr) < 0 ||
      build_rows(sc, jr) < 0) {
    return -1;
  }
  hetinv_result_t r = hetinv_measurements_create(ctx, &sc->set);
  if (r != HETINV_SUCCESS) return scene_lib_fail(jr, "measurements", ctx, r);
  for (int i = 0; i < sc->row_count; ++i) {
    const scene_row_t *row = &sc->rows[i];
    r = hetinv_measurements_add(sc->set, sc->emitters[row->emitter].handle,
                                sc->sensors[row->sensor].handle,
                                sc->pathlengths[row->pathlength].handle, NULL);
    if (r != HETINV_SUCCESS) return scene_lib_fail(jr, "measurements", ctx, r);
  }
  return 0;
}

int scene_configure_estimator(const scene_t *sc, hetinv_estimator_t *est,
                              const char *photons_origin, jr_t *jr) {
  hetinv_context_t *ctx = NULL; /* messages are read from the calling thread */
  hetinv_result_t r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)sc->photons);
  if (r != HETINV_SUCCESS) return scene_lib_fail(jr, photons_origin, ctx, r);
  for (int k = 0; k < SCENE_ESTIMATOR_KEYS; ++k) {
    if (!sc->estimator_given[k]) continue;
    r = hetinv_estimator_set_param(est, estimator_keys[k].param, sc->estimator_value[k]);
    if (r != HETINV_SUCCESS) {
      char at[JR_PATH_MAX];
      jr_key(at, "estimator", estimator_keys[k].key);
      return scene_lib_fail(jr, at, ctx, r);
    }
  }
  return 0;
}

void scene_channel_name(const scene_pathlength_t *pl, int32_t b, char *out, size_t size) {
  if (pl->steady) {
    snprintf(out, size, "L");
  } else if (pl->count > 10000) {
    snprintf(out, size, "tau%05d", (int)b % 100000);
  } else {
    snprintf(out, size, "tau%04d", (int)b % 10000);
  }
}

void scene_destroy(scene_t *sc) {
  hetinv_measurements_destroy(&sc->set);
  for (int i = 0; i < sc->emitter_count; ++i) hetinv_emitter_destroy(&sc->emitters[i].handle);
  for (int i = 0; i < sc->sensor_count; ++i) hetinv_sensor_destroy(&sc->sensors[i].handle);
  for (int i = 0; i < sc->pathlength_count; ++i) {
    hetinv_pathlength_destroy(&sc->pathlengths[i].handle);
    free(sc->pathlengths[i].centres);
    free(sc->pathlengths[i].irf_offsets);
    free(sc->pathlengths[i].irf_samples);
  }
  free(sc->emitters);
  free(sc->sensors);
  free(sc->pathlengths);
  free(sc->rows);
  hetinv_medium_destroy(&sc->medium);
  cJSON_Delete(sc->root);
  free(sc->text);
  memset(sc, 0, sizeof *sc);
}
