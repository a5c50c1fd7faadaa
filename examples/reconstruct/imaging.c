/* The imaging configurations of the paper's Fig. 4, for a cube with a 2D
 * cross-section (grid[1] = 1: sources and pixels on the section's line
 * through the middle of y) or a 3D grid (pixel grids on whole faces).
 *
 * Sources are ideal beams at the centres of boundary pixels, entering
 * along the inward normal tilted by each orientation angle towards the
 * face's in-section axis. Sensors are orthographic pixels looking along
 * the outward normal. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "recon.h"

/* The two in-face axes of a face, as the library orders them (u, v). */
static void face_axes(int face, int *u, int *v) {
  int a = face / 2;
  *u = a == 0 ? 1 : 0;
  *v = a == 2 ? 1 : 2;
}

/* Pixel grid of a face: count and origin along each in-face axis. */
typedef struct face_grid {
  int face, n_axis, u, v, tilt; /* tilt: the in-face axis sources lean towards */
  int32_t count[2];
  double origin[2], pixel;
} face_grid_t;

static void face_grid(const recon_scene_t *sc, int face, face_grid_t *g) {
  bool section = sc->grid[1] == 1;
  g->face = face;
  g->n_axis = face / 2;
  face_axes(face, &g->u, &g->v);
  g->pixel = sc->size / (sc->grid[0] * sc->pixels_per_voxel);
  int axes[2] = {g->u, g->v};
  for (int i = 0; i < 2; ++i) {
    if (section && axes[i] == 1) {
      g->count[i] = 1;
      g->origin[i] = 0.5 * sc->size - 0.5 * g->pixel;
    } else {
      g->count[i] = sc->grid[axes[i]] * sc->pixels_per_voxel;
      g->origin[i] = 0.0;
    }
  }
  /* In the section the line runs along the axis that is not y. */
  g->tilt = section ? (g->u == 1 ? g->v : g->u) : g->u;
}

/* Grows *array of *capacity elements of `size` bytes to hold count + 1. */
static bool grow(void **array, int32_t *capacity, int32_t count, size_t size) {
  if (count < *capacity) return true;
  int32_t cap = *capacity ? 2 * *capacity : 64;
  void *grown = realloc(*array, (size_t)cap * size);
  if (grown == NULL) return false;
  *array = grown;
  *capacity = cap;
  return true;
}

/* Takes e (destroyed here on failure) with its description. */
static hetinv_result_t push_emitter(recon_imaging_t *im, hetinv_emitter_t *e, const double p[3], const double d[3]) {
  int32_t cap = im->capacity_e;
  if (!grow((void **)&im->emitters, &cap, im->emitter_count, sizeof *im->emitters) ||
      !grow((void **)&im->emitter_specs, &im->capacity_e, im->emitter_count, sizeof *im->emitter_specs)) {
    hetinv_emitter_destroy(&e);
    return HETINV_ERROR_OUT_OF_MEMORY;
  }
  recon_emitter_spec_t *spec = &im->emitter_specs[im->emitter_count];
  memcpy(spec->origin, p, sizeof spec->origin);
  memcpy(spec->direction, d, sizeof spec->direction);
  im->emitters[im->emitter_count++] = e;
  return HETINV_SUCCESS;
}

/* Takes s (destroyed here on failure) with its description. */
static hetinv_result_t push_sensor(recon_imaging_t *im, hetinv_sensor_t *s, const recon_sensor_spec_t *spec) {
  int32_t cap = im->capacity_s;
  if (!grow((void **)&im->sensors, &cap, im->sensor_count, sizeof *im->sensors) ||
      !grow((void **)&im->sensor_specs, &im->capacity_s, im->sensor_count, sizeof *im->sensor_specs)) {
    hetinv_sensor_destroy(&s);
    return HETINV_ERROR_OUT_OF_MEMORY;
  }
  im->sensor_specs[im->sensor_count] = *spec;
  im->sensors[im->sensor_count++] = s;
  return HETINV_SUCCESS;
}

/* Adds the row (emitter e, sensor s) to the set and to its description. */
static hetinv_result_t push_row(recon_imaging_t *im, int32_t e, int32_t s, bool bins) {
  if (!grow((void **)&im->row_specs, &im->capacity_r, im->row_count, sizeof *im->row_specs)) {
    return HETINV_ERROR_OUT_OF_MEMORY;
  }
  hetinv_result_t r = hetinv_measurements_add(im->set, im->emitters[e], im->sensors[s], bins ? im->bins : im->steady, NULL);
  if (r == HETINV_SUCCESS) im->row_specs[im->row_count++] = (recon_row_spec_t){e, s, bins};
  return r;
}

/* An orthographic sensor on g's face over pixels [first, first + n) along
 * the tilt axis at pixel `at` of the other in-face axis (n = 0: the whole face). */
static hetinv_result_t make_sensor(const hetinv_medium_t *m, const face_grid_t *g, int32_t first,
                                   int32_t n, int32_t at, recon_imaging_t *im, int32_t *index) {
  recon_sensor_spec_t sp = {.face = g->face, .pixel = {g->pixel, g->pixel}};
  sp.direction[g->n_axis] = (g->face & 1) ? 1.0 : -1.0;
  sp.width = g->count[0];
  sp.height = g->count[1];
  sp.origin[0] = g->origin[0];
  sp.origin[1] = g->origin[1];
  if (n > 0) {
    int line = g->tilt == g->u ? 0 : 1;
    sp.origin[line] += first * g->pixel;
    sp.origin[1 - line] += at * g->pixel;
    sp.width = line == 0 ? n : 1;
    sp.height = line == 0 ? 1 : n;
  }
  hetinv_sensor_t *s = NULL;
  hetinv_result_t r = hetinv_sensor_create_orthographic(m, (hetinv_face_t)g->face, sp.direction, sp.origin, sp.pixel,
                                                        sp.width, sp.height, &s);
  *index = im->sensor_count;
  return r == HETINV_SUCCESS ? push_sensor(im, s, &sp) : r;
}

/* Every stride-th pixel, starting half a stride in, carries a source. */
static bool carries_source(int32_t i, int32_t count, int32_t stride, int32_t half) {
  return count == 1 || i % stride == (half < count ? half : 0);
}

bool recon_has_cameras(const recon_scene_t *sc) {
  return sc->config == RECON_STEADY || sc->config == RECON_COMBINED || sc->config == RECON_PATHLENGTH_CAMERAS;
}

double recon_bin_count(const recon_scene_t *sc) {
  return ceil(sc->max_pathlength / sc->bin_width - 1e-9);
}

/* Pixels i in [0, count) with carries_source(i, count, stride, stride / 2). */
static double source_pixels(int32_t count, int32_t stride) {
  if (count == 1) return 1.0;
  int32_t half = stride / 2, h = half < count ? half : 0;
  return (double)((count - 1 - h) / stride + 1);
}

void recon_imaging_size(const recon_scene_t *sc, recon_imaging_size_t *size) {
  bool transient = sc->config != RECON_STEADY;
  bool probes = transient && sc->config != RECON_PATHLENGTH_CAMERAS; /* sensors at the source pixel */
  double bins = transient ? recon_bin_count(sc) : 0.0;
  double cameras = 0.0, camera_pixels = 0.0; /* cameras, their values per emitter in all */
  for (int f = 0; recon_has_cameras(sc) && f < 6; ++f) {
    if (!(sc->camera_faces & (1u << f))) continue;
    face_grid_t g;
    face_grid(sc, f, &g);
    cameras += 1.0;
    camera_pixels += (double)g.count[0] * (double)g.count[1] * (sc->config == RECON_PATHLENGTH_CAMERAS ? bins : 1.0);
  }
  int32_t normal = 0; /* orientations at normal incidence */
  for (int32_t a = 0; a < sc->angle_count; ++a) normal += sc->angles[a] == 0.0;
  int32_t orientations = sc->config == RECON_PATHLENGTH ? normal : sc->angle_count;
  int32_t probed = sc->config == RECON_PATHLENGTH_ANGLES ? sc->angle_count : normal;
  *size = (recon_imaging_size_t){0.0, 0.0, 0.0};
  for (int f = 0; f < 6; ++f) {
    if (!(sc->source_faces & (1u << f))) continue;
    face_grid_t g;
    face_grid(sc, f, &g);
    double sources = source_pixels(g.count[0], sc->source_stride) *
                     source_pixels(g.count[1], sc->source_stride);
    double emitters = sources * orientations;
    size->emitters += emitters;
    size->rows += emitters * cameras;
    size->values += emitters * camera_pixels;
    if (probes) { /* one row per probed emitter, up to 3 pixels of all bins */
      size->rows += sources * probed;
      size->values += sources * probed * 3.0 * bins;
    }
  }
}

hetinv_result_t recon_imaging_build(hetinv_context_t *ctx, const hetinv_medium_t *m,
                                    const recon_scene_t *sc, recon_imaging_t *im) {
  memset(im, 0, sizeof *im);
  hetinv_result_t r = hetinv_measurements_create(ctx, &im->set);
  if (r == HETINV_SUCCESS) r = hetinv_pathlength_create_steady(ctx, &im->steady);
  bool transient = sc->config != RECON_STEADY;
  bool probes = transient && sc->config != RECON_PATHLENGTH_CAMERAS; /* sensors at the source pixel */
  bool camera_bins = sc->config == RECON_PATHLENGTH_CAMERAS;
  if (r == HETINV_SUCCESS && transient) {
    int32_t nb = (int32_t)ceil(sc->max_pathlength / sc->bin_width - 1e-9);
    double *centres = malloc((size_t)nb * sizeof *centres);
    for (int32_t i = 0; centres != NULL && i < nb; ++i) centres[i] = (i + 0.5) * sc->bin_width;
    r = centres == NULL ? HETINV_ERROR_OUT_OF_MEMORY
                        : hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, nb, centres, sc->bin_width, &im->bins);
    free(centres);
    im->bin_count = nb;
    im->bin_width = sc->bin_width;
  }
  /* Cameras: one per camera face, the whole pixel grid. */
  int32_t cameras[6] = {-1, -1, -1, -1, -1, -1}; /* sensor index per face */
  for (int f = 0; r == HETINV_SUCCESS && recon_has_cameras(sc) && f < 6; ++f) {
    if (!(sc->camera_faces & (1u << f))) continue;
    face_grid_t g;
    face_grid(sc, f, &g);
    r = make_sensor(m, &g, 0, 0, 0, im, &cameras[f]);
  }
  for (int f = 0; r == HETINV_SUCCESS && f < 6; ++f) {
    if (!(sc->source_faces & (1u << f))) continue;
    face_grid_t g;
    face_grid(sc, f, &g);
    int line = g.tilt == g.u ? 0 : 1;
    double n_in[3] = {0, 0, 0}, t[3] = {0, 0, 0};
    n_in[g.n_axis] = (f & 1) ? -1.0 : 1.0;
    t[g.tilt] = 1.0;
    int32_t s = sc->source_stride, half = s / 2;
    for (int32_t iv = 0; r == HETINV_SUCCESS && iv < g.count[1]; ++iv) {
      for (int32_t iu = 0; r == HETINV_SUCCESS && iu < g.count[0]; ++iu) {
        if (!carries_source(iu, g.count[0], s, half) || !carries_source(iv, g.count[1], s, half)) continue;
        double p[3];
        p[g.n_axis] = (f & 1) ? sc->size : 0.0;
        p[g.u] = g.origin[0] + (iu + 0.5) * g.pixel;
        p[g.v] = g.origin[1] + (iv + 0.5) * g.pixel;
        int32_t il = line == 0 ? iu : iv, across = line == 0 ? iv : iu, nl = g.count[line];
        for (int32_t a = 0; r == HETINV_SUCCESS && a < sc->angle_count; ++a) {
          double th = sc->angles[a] * (3.14159265358979323846 / 180.0), d[3];
          bool normal = sc->angles[a] == 0.0;
          if (sc->config == RECON_PATHLENGTH && !normal) continue;
          for (int k = 0; k < 3; ++k) d[k] = n_in[k] * cos(th) + t[k] * sin(th);
          hetinv_emitter_t *e = NULL;
          r = hetinv_emitter_create_ideal(m, p, d, &e);
          int32_t ei = im->emitter_count;
          if (r == HETINV_SUCCESS) r = push_emitter(im, e, p, d);
          /* Pathlength rows: the source pixel (and its neighbours in (1), (4)). */
          if (r == HETINV_SUCCESS && probes && (sc->config == RECON_PATHLENGTH_ANGLES || normal)) {
            int32_t first = il, count = 1;
            if (sc->config != RECON_PATHLENGTH_ANGLES) {
              first = il > 0 ? il - 1 : 0;
              count = (il + 1 < nl ? il + 1 : il) - first + 1;
            }
            int32_t probe = -1;
            r = make_sensor(m, &g, first, count, across, im, &probe);
            if (r == HETINV_SUCCESS) r = push_row(im, ei, probe, true);
            if (r == HETINV_SUCCESS) ++im->rows_pathlength;
          }
          for (int c = 0; r == HETINV_SUCCESS && c < 6; ++c) {
            if (cameras[c] >= 0) r = push_row(im, ei, cameras[c], camera_bins);
          }
        }
      }
    }
  }
  if (r != HETINV_SUCCESS) recon_imaging_release(im);
  return r;
}

void recon_imaging_release(recon_imaging_t *im) {
  hetinv_measurements_destroy(&im->set);
  if (im->files_release != NULL) im->files_release(im->files);
  for (int32_t i = 0; i < im->emitter_count; ++i) hetinv_emitter_destroy(&im->emitters[i]);
  for (int32_t i = 0; i < im->sensor_count; ++i) hetinv_sensor_destroy(&im->sensors[i]);
  free(im->emitters);
  free(im->sensors);
  free(im->emitter_specs);
  free(im->sensor_specs);
  free(im->row_specs);
  hetinv_pathlength_destroy(&im->steady);
  hetinv_pathlength_destroy(&im->bins);
  memset(im, 0, sizeof *im);
}
