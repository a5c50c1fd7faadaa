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

static hetinv_result_t push_emitter(recon_imaging_t *im, hetinv_emitter_t *e) {
  if (im->emitter_count == im->capacity_e) {
    int32_t cap = im->capacity_e ? 2 * im->capacity_e : 64;
    hetinv_emitter_t **grown = realloc(im->emitters, (size_t)cap * sizeof *grown);
    if (grown == NULL) return HETINV_ERROR_OUT_OF_MEMORY;
    im->emitters = grown;
    im->capacity_e = cap;
  }
  im->emitters[im->emitter_count++] = e;
  return HETINV_SUCCESS;
}

static hetinv_result_t push_sensor(recon_imaging_t *im, hetinv_sensor_t *s) {
  if (im->sensor_count == im->capacity_s) {
    int32_t cap = im->capacity_s ? 2 * im->capacity_s : 64;
    hetinv_sensor_t **grown = realloc(im->sensors, (size_t)cap * sizeof *grown);
    if (grown == NULL) return HETINV_ERROR_OUT_OF_MEMORY;
    im->sensors = grown;
    im->capacity_s = cap;
  }
  im->sensors[im->sensor_count++] = s;
  return HETINV_SUCCESS;
}

/* An orthographic sensor on g's face over pixels [first, first + n) along
 * the tilt axis at pixel `at` of the other in-face axis (n = 0: the whole face). */
static hetinv_result_t make_sensor(const hetinv_medium_t *m, const face_grid_t *g, int32_t first,
                                   int32_t n, int32_t at, hetinv_sensor_t **out) {
  double dir[3] = {0, 0, 0}, origin[2], size[2] = {g->pixel, g->pixel};
  dir[g->n_axis] = (g->face & 1) ? 1.0 : -1.0;
  int32_t w = g->count[0], h = g->count[1];
  origin[0] = g->origin[0];
  origin[1] = g->origin[1];
  if (n > 0) {
    int line = g->tilt == g->u ? 0 : 1;
    origin[line] += first * g->pixel;
    origin[1 - line] += at * g->pixel;
    w = line == 0 ? n : 1;
    h = line == 0 ? 1 : n;
  }
  return hetinv_sensor_create_orthographic(m, (hetinv_face_t)g->face, dir, origin, size, w, h, out);
}

/* Every stride-th pixel, starting half a stride in, carries a source. */
static bool carries_source(int32_t i, int32_t count, int32_t stride, int32_t half) {
  return count == 1 || i % stride == (half < count ? half : 0);
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
  bool steady = sc->config == RECON_STEADY || sc->config == RECON_COMBINED;
  double bins = transient ? recon_bin_count(sc) : 0.0;
  double cameras = 0.0, camera_pixels = 0.0; /* steady-state cameras, their pixels in all */
  for (int f = 0; steady && f < 6; ++f) {
    if (!(sc->camera_faces & (1u << f))) continue;
    face_grid_t g;
    face_grid(sc, f, &g);
    cameras += 1.0;
    camera_pixels += (double)g.count[0] * (double)g.count[1];
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
    if (transient) { /* one row per probed emitter, up to 3 pixels of all bins */
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
  bool steady = sc->config == RECON_STEADY || sc->config == RECON_COMBINED;
  if (r == HETINV_SUCCESS && transient) {
    int32_t nb = (int32_t)ceil(sc->max_pathlength / sc->bin_width - 1e-9);
    double *centres = malloc((size_t)nb * sizeof *centres);
    if (centres == NULL) return HETINV_ERROR_OUT_OF_MEMORY;
    for (int32_t i = 0; i < nb; ++i) centres[i] = (i + 0.5) * sc->bin_width;
    r = hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, nb, centres, sc->bin_width, &im->bins);
    free(centres);
  }
  /* Steady-state cameras: one per camera face, the whole pixel grid. */
  hetinv_sensor_t *cameras[6] = {NULL};
  for (int f = 0; r == HETINV_SUCCESS && steady && f < 6; ++f) {
    if (!(sc->camera_faces & (1u << f))) continue;
    face_grid_t g;
    face_grid(sc, f, &g);
    r = make_sensor(m, &g, 0, 0, 0, &cameras[f]);
    if (r == HETINV_SUCCESS) r = push_sensor(im, cameras[f]);
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
          if (r == HETINV_SUCCESS) r = push_emitter(im, e);
          /* Pathlength rows: the source pixel (and its neighbours in (1), (4)). */
          if (r == HETINV_SUCCESS && transient && (sc->config == RECON_PATHLENGTH_ANGLES || normal)) {
            int32_t first = il, count = 1;
            if (sc->config != RECON_PATHLENGTH_ANGLES) {
              first = il > 0 ? il - 1 : 0;
              count = (il + 1 < nl ? il + 1 : il) - first + 1;
            }
            hetinv_sensor_t *probe = NULL;
            r = make_sensor(m, &g, first, count, across, &probe);
            if (r == HETINV_SUCCESS) r = push_sensor(im, probe);
            if (r == HETINV_SUCCESS) r = hetinv_measurements_add(im->set, e, probe, im->bins, NULL);
            if (r == HETINV_SUCCESS) ++im->rows_pathlength;
          }
          for (int c = 0; r == HETINV_SUCCESS && steady && c < 6; ++c) {
            if (cameras[c]) r = hetinv_measurements_add(im->set, e, cameras[c], im->steady, NULL);
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
  hetinv_pathlength_destroy(&im->steady);
  hetinv_pathlength_destroy(&im->bins);
  memset(im, 0, sizeof *im);
}
