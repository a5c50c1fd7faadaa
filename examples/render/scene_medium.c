/* "medium" (with "box", "eta", "eta_out") → a committed hetinv medium.
 *
 * The base is "uniform", "layers" (along z) or "vol" (Mitsuba .vol files);
 * "inclusions" (spheres, Gaussian blobs) are then painted over it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene.h"

static const char *const param_keys[HETINV_PARAM_COUNT] = {"sigma_a", "sigma_s", "g"};

/* Most voxels a scene may ask for: the library's bound, checked here
 * before the scene's own grids are allocated. */
#define MAX_VOXELS ((int64_t)HETINV_MAX_VOXELS)

/* Checks one parameter value: σ ≥ 0, -1 < g < 1. */
static int check_param(jr_t *jr, const char *at, int p, double v) {
  if (p == HETINV_PARAM_G && !(v > -1.0 && v < 1.0)) {
    return jr_fail(jr, at, "is %g; it must be > -1 and < 1", v);
  }
  if (p != HETINV_PARAM_G && v < 0.0) return jr_fail(jr, at, "is %g; it must be >= 0", v);
  return 0;
}

/* Reads the optional members sigma_a, sigma_s and g of obj, checked.
 * given[p] says which were there; required_mask (bit p) which must be. */
static int read_params(jr_t *jr, const cJSON *obj, const char *path, unsigned required_mask,
                       double v[HETINV_PARAM_COUNT], int given[HETINV_PARAM_COUNT]) {
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    int r = jr_number(jr, obj, path, param_keys[p], (required_mask >> p) & 1u, &v[p]);
    if (r < 0) return -1;
    given[p] = r;
    char at[JR_PATH_MAX];
    jr_key(at, path, param_keys[p]);
    if (r && check_param(jr, at, p, v[p]) < 0) return -1;
  }
  return 0;
}

/* "box": {"min": [x, y, z], "max": [x, y, z]}. Returns 1 if present. */
static int read_box(scene_t *sc, jr_t *jr, int required) {
  const cJSON *box = NULL;
  int r = jr_object(jr, sc->root, "", "box", required, &box);
  if (r <= 0) return r;
  static const char *const allowed[] = {"min", "max", NULL};
  if (jr_check_object(jr, box, "box", allowed) < 0 ||
      jr_numbers(jr, box, "box", "min", JR_REQUIRED, 3, sc->box_min) < 0 ||
      jr_numbers(jr, box, "box", "max", JR_REQUIRED, 3, sc->box_max) < 0) {
    return -1;
  }
  for (int a = 0; a < 3; ++a) {
    if (!(sc->box_min[a] < sc->box_max[a])) {
      char at[JR_PATH_MAX];
      jr_index(at, "box.max", a);
      return jr_fail(jr, at, "is %g; it must be above box.min[%d] = %g", sc->box_max[a], a,
                     sc->box_min[a]);
    }
  }
  return 1;
}

/* "dims": [nx, ny, nz], positive integers. Returns 1 if present. */
static int read_dims(jr_t *jr, const cJSON *medium, int32_t dims[3]) {
  double d[3];
  int r = jr_numbers(jr, medium, "medium", "dims", JR_OPTIONAL, 3, d);
  if (r <= 0) return r;
  int64_t total = 1;
  for (int a = 0; a < 3; ++a) {
    if (!(d[a] >= 1.0 && d[a] <= 1e6 && d[a] == floor(d[a]))) {
      char at[JR_PATH_MAX];
      jr_index(at, "medium.dims", a);
      return jr_fail(jr, at, "is %g; it must be an integer from 1 to 1000000", d[a]);
    }
    dims[a] = (int32_t)d[a];
    total *= dims[a];
    if (total > MAX_VOXELS) {
      return jr_fail(jr, "medium.dims", "more than %lld voxels (HETINV_MAX_VOXELS)", (long long)MAX_VOXELS);
    }
  }
  return 1;
}

/* The grid arrays of the three parameters. */
typedef struct grids {
  size_t n;
  double *v[HETINV_PARAM_COUNT];
} grids_t;

static int grids_alloc(jr_t *jr, grids_t *g, const int32_t dims[3]) {
  g->n = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    g->v[p] = calloc(g->n, sizeof(double));
    if (g->v[p] == NULL) return jr_fail(jr, "medium", "out of memory for %zu voxels", g->n);
  }
  return 0;
}

static void grids_free(grids_t *g) {
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) free(g->v[p]);
}

static int build_uniform(scene_t *sc, jr_t *jr, const cJSON *medium, const cJSON *uniform,
                         grids_t *g) {
  static const char *const allowed[] = {"sigma_a", "sigma_s", "g", NULL};
  double v[HETINV_PARAM_COUNT] = {0, 0, 0};
  int given[HETINV_PARAM_COUNT];
  if (read_box(sc, jr, JR_REQUIRED) < 0 ||
      jr_check_object(jr, uniform, "medium.uniform", allowed) < 0 ||
      read_params(jr, uniform, "medium.uniform", 3u, v, given) < 0) {
    return -1;
  }
  sc->dims[0] = sc->dims[1] = sc->dims[2] = 1;
  if (read_dims(jr, medium, sc->dims) < 0 || grids_alloc(jr, g, sc->dims) < 0) return -1;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    for (size_t i = 0; i < g->n; ++i) g->v[p][i] = v[p];
  }
  return 0;
}

typedef enum { LAYERS_FIT, LAYERS_OFF_BOUNDARY, LAYERS_EMPTY_LAYER } layers_fit_t;

/* Is every interior layer boundary (fractions f[0..count-1] of the depth) on
 * a voxel boundary of nz voxels, and every layer at least one voxel thick?
 * The tolerance is a millionth of a voxel, so a layer thinner than that
 * would otherwise pass with no voxel of its own and vanish from the
 * medium. On a failure *bad is the boundary that is off, or the layer
 * left without a voxel. */
static layers_fit_t layers_fit(const double *f, int count, int32_t nz, int *bad) {
  double below = 0.0; /* the last boundary's voxel index */
  for (int k = 0; k <= count; ++k) {
    double x = k < count ? f[k] * nz : nz;
    double at = floor(x + 0.5);
    *bad = k;
    if (k < count && fabs(x - at) > 1e-6) return LAYERS_OFF_BOUNDARY;
    if (!(at > below)) return LAYERS_EMPTY_LAYER;
    below = at;
  }
  return LAYERS_FIT;
}

static double thinnest(const double *thick, int count) {
  double t = thick[0];
  for (int k = 1; k < count; ++k) t = fmin(t, thick[k]);
  return t;
}

static int build_layers(scene_t *sc, jr_t *jr, const cJSON *medium, const cJSON *layers,
                        grids_t *g) {
  int count = cJSON_GetArraySize(layers);
  if (!cJSON_IsArray(layers) || count < 1) {
    char buf[96];
    return jr_fail(jr, "medium.layers", "expected an array of at least 1 layer, found %s",
                   jr_describe(layers, buf, sizeof buf));
  }
  if (read_box(sc, jr, JR_REQUIRED) < 0) return -1;
  int from_top = 0;
  static const char *const ends[] = {"z_min", "z_max", NULL};
  if (jr_choice(jr, medium, "medium", "layers_from", JR_OPTIONAL, ends, &from_top) < 0) return -1;

  double *thick = calloc((size_t)count, sizeof *thick);
  double(*val)[HETINV_PARAM_COUNT] = calloc((size_t)count, sizeof *val);
  double *frac = calloc((size_t)count, sizeof *frac); /* cumulative boundaries / depth */
  int status = -1;
  if (thick == NULL || val == NULL || frac == NULL) {
    jr_fail(jr, "medium.layers", "out of memory");
    goto done;
  }
  static const char *const allowed[] = {"thickness", "sigma_a", "sigma_s", "g", NULL};
  double total = 0.0;
  int i = 0;
  const cJSON *layer;
  cJSON_ArrayForEach(layer, layers) {
    char at[JR_PATH_MAX];
    jr_index(at, "medium.layers", i);
    int given[HETINV_PARAM_COUNT];
    if (jr_check_object(jr, layer, at, allowed) < 0 ||
        jr_positive(jr, layer, at, "thickness", JR_REQUIRED, &thick[i]) < 0 ||
        read_params(jr, layer, at, 3u, val[i], given) < 0) {
      goto done;
    }
    total += thick[i];
    ++i;
  }
  double depth = sc->box_max[2] - sc->box_min[2];
  if (fabs(total - depth) > 1e-9 * depth) {
    jr_fail(jr, "medium.layers", "the thicknesses add up to %.9g but the box is %.9g deep "
            "(box.max[2] - box.min[2]); they must be equal", total, depth);
    goto done;
  }
  double cum = 0.0;
  for (int k = 0; k < count; ++k) {
    cum += thick[k];
    frac[k] = cum / total;
  }
  sc->dims[0] = sc->dims[1] = 1;
  int bad = 0, r = read_dims(jr, medium, sc->dims);
  if (r < 0) goto done;
  layers_fit_t fit = r == 1 ? layers_fit(frac, count - 1, sc->dims[2], &bad) : LAYERS_FIT;
  if (fit != LAYERS_FIT) {
    if (fit == LAYERS_EMPTY_LAYER) {
      jr_fail(jr, "medium.dims", "nz = %d leaves medium.layers[%d] (counted from %s) without a voxel of its own; "
              "choose nz so that every layer is a whole number of voxels thick (or leave \"dims\" out)",
              (int)sc->dims[2], bad, from_top ? "z_max" : "z_min");
    } else {
      jr_fail(jr, "medium.dims", "nz = %d puts no voxel boundary at the boundary between "
              "medium.layers[%d] and [%d]; choose nz so that every layer is a whole number of "
              "voxels thick (or leave \"dims\" out)", (int)sc->dims[2], bad, bad + 1);
    }
    goto done;
  }
  if (r == 0) { /* the coarsest grid whose voxel boundaries include the layer boundaries */
    int32_t nz = 1;
    while (nz <= 100000 && layers_fit(frac, count - 1, nz, &bad) != LAYERS_FIT) ++nz;
    if (nz > 100000) {
      jr_fail(jr, "medium.layers", "no grid of up to 100000 voxels along z has a voxel "
              "boundary at every layer boundary and a voxel in every layer (the thinnest is %.3g of "
              "the depth); give \"dims\" explicitly", thinnest(thick, count) / total);
      goto done;
    }
    sc->dims[2] = nz;
  }
  if (grids_alloc(jr, g, sc->dims) < 0) goto done;
  size_t plane = (size_t)sc->dims[0] * (size_t)sc->dims[1];
  for (int32_t iz = 0; iz < sc->dims[2]; ++iz) {
    double z = (iz + 0.5) / sc->dims[2]; /* fraction of the depth from z_min */
    if (from_top) z = 1.0 - z;
    int k = 0;
    while (k < count - 1 && frac[k] < z) ++k;
    for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
      for (size_t j = 0; j < plane; ++j) g->v[p][(size_t)iz * plane + j] = val[k][p];
    }
  }
  status = 0;
done:
  free(thick);
  free(val);
  free(frac);
  return status;
}

/* path relative to the scene file's folder unless absolute. */
static void scene_relative(const scene_t *sc, const char *path, char *out, size_t size) {
  if (path[0] == '/' || strcmp(sc->dir, ".") == 0) {
    snprintf(out, size, "%s", path);
  } else {
    snprintf(out, size, "%s/%s", sc->dir, path);
  }
}

/* Without a scene "box" the first file's box is the medium's; the other
 * files must have it too, else one of them was written in another unit or
 * at another origin and would be read onto the wrong voxels' places. */
static int check_vol_boxes(hetinv_context_t *ctx, jr_t *jr, char (*files)[4400], const int *is_file, int first,
                           const hetinv_vol_header_t *head) {
  for (int p = first + 1; p < HETINV_PARAM_COUNT; ++p) {
    if (!is_file[p]) continue;
    char at[JR_PATH_MAX];
    jr_key(at, "medium.vol", param_keys[p]);
    hetinv_vol_header_t h;
    hetinv_result_t r = hetinv_vol_read_header(ctx, files[p], &h);
    if (r != HETINV_SUCCESS) return scene_lib_fail(jr, at, ctx, r);
    for (int i = 0; i < 3; ++i) {
      double scale = fmax(fmax(fabs(head->box_min[i]), fabs(head->box_max[i])), 1e-300);
      if (fabs(h.box_min[i] - head->box_min[i]) > 1e-6 * scale || fabs(h.box_max[i] - head->box_max[i]) > 1e-6 * scale) {
        return jr_fail(jr, at, "the file's box [%.9g, %.9g] x [%.9g, %.9g] x [%.9g, %.9g] is not medium.vol.%s's "
                       "[%.9g, %.9g] x [%.9g, %.9g] x [%.9g, %.9g] (another unit or origin?); a scene \"box\" "
                       "sets the box of every file", h.box_min[0], h.box_max[0], h.box_min[1], h.box_max[1],
                       h.box_min[2], h.box_max[2], param_keys[first], head->box_min[0], head->box_max[0],
                       head->box_min[1], head->box_max[1], head->box_min[2], head->box_max[2]);
      }
    }
  }
  return 0;
}

static int build_vol(scene_t *sc, hetinv_context_t *ctx, jr_t *jr, const cJSON *medium,
                     const cJSON *vol, grids_t *g) {
  static const char *const allowed[] = {"sigma_a", "sigma_s", "g", NULL};
  if (jr_check_object(jr, vol, "medium.vol", allowed) < 0) return -1;
  if (jr_get(medium, "dims") != NULL) {
    return jr_fail(jr, "medium.dims", "not allowed with \"vol\": the .vol files give the grid");
  }
  char files[HETINV_PARAM_COUNT][4400];
  double value[HETINV_PARAM_COUNT] = {0, 0, 0};
  int is_file[HETINV_PARAM_COUNT] = {0, 0, 0}, first = -1;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    char at[JR_PATH_MAX];
    jr_key(at, "medium.vol", param_keys[p]);
    const cJSON *item = jr_get(vol, param_keys[p]);
    if (cJSON_IsString(item)) {
      const char *name = NULL;
      if (jr_string(jr, vol, "medium.vol", param_keys[p], JR_REQUIRED, &name) < 0) return -1;
      scene_relative(sc, name, files[p], sizeof files[p]);
      is_file[p] = 1;
      if (first < 0) first = p;
    } else if (item != NULL || p != HETINV_PARAM_G) { /* g defaults to 0 */
      if (item == NULL) {
        return jr_fail(jr, at, "missing (required): a .vol file name or a number");
      }
      if (!cJSON_IsNumber(item) || !isfinite(item->valuedouble)) {
        char buf[96];
        return jr_fail(jr, at, "expected a .vol file name or a number, found %s",
                       jr_describe(item, buf, sizeof buf));
      }
      value[p] = item->valuedouble;
      if (check_param(jr, at, p, value[p]) < 0) return -1;
    }
  }
  if (first < 0) {
    return jr_fail(jr, "medium.vol", "no parameter is a .vol file name (for constant values "
                   "use \"uniform\")");
  }
  char at[JR_PATH_MAX];
  jr_key(at, "medium.vol", param_keys[first]);
  hetinv_vol_header_t header;
  hetinv_result_t r = hetinv_vol_read_header(ctx, files[first], &header);
  if (r != HETINV_SUCCESS) return scene_lib_fail(jr, at, ctx, r);
  int has_box = read_box(sc, jr, JR_OPTIONAL);
  if (has_box < 0) return -1;
  if (!has_box) {
    if (check_vol_boxes(ctx, jr, files, is_file, first, &header) < 0) return -1;
    memcpy(sc->box_min, header.box_min, sizeof sc->box_min);
    memcpy(sc->box_max, header.box_max, sizeof sc->box_max);
  }
  memcpy(sc->dims, header.dims, sizeof sc->dims);
  if ((int64_t)sc->dims[0] * sc->dims[1] * sc->dims[2] > MAX_VOXELS) {
    return jr_fail(jr, at, "%d x %d x %d is more than %lld voxels (HETINV_MAX_VOXELS)",
                   (int)sc->dims[0], (int)sc->dims[1], (int)sc->dims[2], (long long)MAX_VOXELS);
  }
  r = hetinv_medium_create(ctx, sc->box_min, sc->box_max, sc->dims, &sc->medium);
  if (r != HETINV_SUCCESS && !has_box && r == HETINV_ERROR_INVALID_ARGUMENT) {
    /* Mitsuba files may carry an empty box: say where it came from. */
    return jr_fail(jr, at, "%s (%s): the box is the .vol file's header's; a scene \"box\" replaces it",
                   hetinv_context_last_error_message(ctx), hetinv_result_name(r));
  }
  if (r != HETINV_SUCCESS) return scene_lib_fail(jr, has_box ? "box" : at, ctx, r);
  if (grids_alloc(jr, g, sc->dims) < 0) return -1;
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    if (is_file[p] && sc->geometry_only) {
      continue; /* the header gave the grid; the values are not wanted */
    } else if (is_file[p]) {
      jr_key(at, "medium.vol", param_keys[p]);
      r = hetinv_medium_read_vol(sc->medium, p, files[p]);
      if (r != HETINV_SUCCESS) return scene_lib_fail(jr, at, ctx, r);
      memcpy(g->v[p], hetinv_medium_grid(sc->medium, p), g->n * sizeof(double));
    } else {
      for (size_t i = 0; i < g->n; ++i) g->v[p][i] = value[p];
    }
  }
  return 0;
}

/* Paints "inclusions" over the grids: spheres (hard) or Gaussian blobs. */
static int paint_inclusions(scene_t *sc, jr_t *jr, const cJSON *medium, grids_t *g) {
  const cJSON *list = NULL;
  int count = 0;
  int r = jr_array(jr, medium, "medium", "inclusions", JR_OPTIONAL, 0, &list, &count);
  if (r <= 0) return r; /* an error, or no inclusions */
  static const char *const allowed[] = {"shape", "centre", "radius", "sigma_a", "sigma_s", "g", NULL};
  static const char *const shapes[] = {"sphere", "gaussian", NULL};
  double step[3];
  for (int a = 0; a < 3; ++a) step[a] = (sc->box_max[a] - sc->box_min[a]) / sc->dims[a];
  int i = 0;
  const cJSON *inc;
  cJSON_ArrayForEach(inc, list) {
    char at[JR_PATH_MAX];
    jr_index(at, "medium.inclusions", i++);
    int shape = 0, given[HETINV_PARAM_COUNT];
    double centre[3], radius = 0.0, v[HETINV_PARAM_COUNT] = {0, 0, 0};
    if (jr_check_object(jr, inc, at, allowed) < 0 ||
        jr_choice(jr, inc, at, "shape", JR_OPTIONAL, shapes, &shape) < 0 ||
        jr_numbers(jr, inc, at, "centre", JR_REQUIRED, 3, centre) < 0 ||
        jr_positive(jr, inc, at, "radius", JR_REQUIRED, &radius) < 0 ||
        read_params(jr, inc, at, 0u, v, given) < 0) {
      return -1;
    }
    if (!given[0] && !given[1] && !given[2]) {
      return jr_fail(jr, at, "sets none of \"sigma_a\", \"sigma_s\", \"g\"");
    }
    /* The weights divide by 2 radius²: out of double's normal range it
     * makes 0/0 at the centre or inf/inf far out, NaN values the library
     * would then blame on the medium. */
    if (!isnormal(2.0 * radius * radius)) {
      char key[JR_PATH_MAX];
      jr_key(key, at, "radius");
      return jr_fail(jr, key, "is %g; 2 radius² must lie in double's normal range (a radius from "
                     "about 1e-154 to 1e154): choose a length unit nearer the medium's size", radius);
    }
    for (int32_t iz = 0; iz < sc->dims[2]; ++iz) {
      for (int32_t iy = 0; iy < sc->dims[1]; ++iy) {
        for (int32_t ix = 0; ix < sc->dims[0]; ++ix) {
          const int32_t idx[3] = {ix, iy, iz};
          double d2 = 0.0;
          for (int a = 0; a < 3; ++a) {
            double x = sc->box_min[a] + (idx[a] + 0.5) * step[a] - centre[a];
            d2 += x * x;
          }
          size_t k = (size_t)ix + (size_t)sc->dims[0] * ((size_t)iy + (size_t)sc->dims[1] * (size_t)iz);
          double w = shape == 0 ? (d2 <= radius * radius ? 1.0 : 0.0)
                                : exp(-d2 / (2.0 * radius * radius));
          for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
            if (given[p]) g->v[p][k] += (v[p] - g->v[p][k]) * w;
          }
        }
      }
    }
  }
  return 0;
}

int scene_build_medium(scene_t *sc, hetinv_context_t *ctx, jr_t *jr) {
  sc->eta = 1.0;
  sc->eta_out = 1.0;
  if (jr_positive(jr, sc->root, "", "eta", JR_OPTIONAL, &sc->eta) < 0 ||
      jr_positive(jr, sc->root, "", "eta_out", JR_OPTIONAL, &sc->eta_out) < 0) {
    return -1;
  }
  const cJSON *medium = NULL;
  if (jr_object(jr, sc->root, "", "medium", JR_REQUIRED, &medium) < 0) return -1;
  static const char *const allowed[] = {"uniform", "layers", "layers_from", "vol", "dims",
                                        "inclusions", NULL};
  if (jr_check_object(jr, medium, "medium", allowed) < 0) return -1;
  static const char *const kinds[] = {"uniform", "layers", "vol"};
  const cJSON *base = NULL;
  for (int k = 0; k < 3; ++k) {
    const cJSON *item = jr_get(medium, kinds[k]);
    if (item == NULL) continue;
    if (base != NULL) {
      return jr_fail(jr, "medium", "give exactly one of \"uniform\", \"layers\", \"vol\" "
                     "(found \"%s\" and \"%s\")", sc->medium_kind, kinds[k]);
    }
    base = item;
    sc->medium_kind = kinds[k];
  }
  if (base == NULL) return jr_fail(jr, "medium", "give one of \"uniform\", \"layers\", \"vol\"");
  if (strcmp(sc->medium_kind, "layers") != 0 && jr_get(medium, "layers_from") != NULL) {
    return jr_fail(jr, "medium.layers_from", "only allowed with \"layers\"");
  }

  grids_t g = {0, {NULL, NULL, NULL}};
  int status = -1;
  int rc;
  if (strcmp(sc->medium_kind, "uniform") == 0) {
    if (!cJSON_IsObject(base)) {
      char buf[96];
      jr_fail(jr, "medium.uniform", "expected an object, found %s", jr_describe(base, buf, sizeof buf));
      goto done;
    }
    rc = build_uniform(sc, jr, medium, base, &g);
  } else if (strcmp(sc->medium_kind, "layers") == 0) {
    rc = build_layers(sc, jr, medium, base, &g);
  } else {
    rc = build_vol(sc, ctx, jr, medium, base, &g);
  }
  if (rc < 0 || paint_inclusions(sc, jr, medium, &g) < 0) goto done;
  hetinv_result_t r = HETINV_SUCCESS;
  if (sc->medium == NULL) r = hetinv_medium_create(ctx, sc->box_min, sc->box_max, sc->dims, &sc->medium);
  if (r != HETINV_SUCCESS) {
    scene_lib_fail(jr, "box", ctx, r);
    goto done;
  }
  r = hetinv_medium_set_ior(sc->medium, sc->eta, sc->eta_out);
  if (r != HETINV_SUCCESS) {
    scene_lib_fail(jr, "eta", ctx, r);
    goto done;
  }
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    r = hetinv_medium_set_grid(sc->medium, p, g.v[p], g.n);
    if (r != HETINV_SUCCESS) {
      scene_lib_fail(jr, "medium", ctx, r);
      goto done;
    }
  }
  r = hetinv_medium_commit(sc->medium);
  if (r != HETINV_SUCCESS) {
    scene_lib_fail(jr, "medium", ctx, r);
    goto done;
  }
  status = 0;
done:
  grids_free(&g);
  return status;
}
