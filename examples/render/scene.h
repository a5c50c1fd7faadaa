/* A render scene: the JSON description (docs/scene-format.md) turned into
 * library objects — a committed medium, emitters, sensors, pathlength
 * windows and one measurement set whose rows are the images to render.
 */
#ifndef HETINV_RENDER_SCENE_H
#define HETINV_RENDER_SCENE_H

#include <stdbool.h>
#include <stdint.h>

#include <hetinv/hetinv.h>
#include <hetinv/acquire.h>
#include <hetinv/estimator.h>
#include <hetinv/measurement.h>
#include <hetinv/sampling.h>

#include "faces.h"
#include "jsonread.h"

/** Members of "estimator": batches, roulette_weight, roulette_survival,
 *  min_scattering, max_scattering, stream. */
#define SCENE_ESTIMATOR_KEYS 6

/** Longest emitter, sensor or pathlength name, terminator included. */
#define SCENE_NAME_MAX 64

typedef enum { SENSOR_ORTHOGRAPHIC = 0, SENSOR_HEMISPHERICAL = 1, SENSOR_FIBER = 2 } scene_sensor_kind_t;

/** The scene's "type" of a sensor kind ("orthographic", "hemispherical", "fiber"). */
const char *scene_sensor_type(scene_sensor_kind_t kind);

typedef struct scene_emitter {
  char name[SCENE_NAME_MAX];
  const char *type;        /* "ideal", "area", "diffuse" or "combination" */
  const cJSON *json;       /* its description, for the output's attributes */
  hetinv_emitter_t *handle;
} scene_emitter_t;

typedef struct scene_sensor {
  char name[SCENE_NAME_MAX];
  scene_sensor_kind_t kind;
  hetinv_face_t face;
  double direction[3];             /* orthographic: direction of the light it sees */
  double origin[2], pixel_size[2]; /* orthographic: pixel (0, 0)'s corner; pixel extent */
  int32_t width, height;           /* orthographic: pixels; hemispherical and fiber: 1 × 1 */
  int has_rect;                    /* hemispherical: 0 for the whole face */
  double rect_min[2], rect_max[2];
  double centre[2], radius, numerical_aperture; /* fiber: its disk on the face and NA */
  const cJSON *json;
  hetinv_sensor_t *handle;
} scene_sensor_t;

typedef struct scene_pathlength {
  char name[SCENE_NAME_MAX];
  int steady;              /* 1: W_τ = 1, one bin */
  hetinv_window_t window;  /* bins: HETINV_WINDOW_BOX or _GAUSSIAN */
  int32_t count;           /* bins (1 for steady state) */
  double *centres;         /* bins: count centres */
  double width;            /* bins: width (box) or standard deviation (Gaussian) */
  int32_t irf_count;       /* bins: IRF samples (0: none) */
  double *irf_offsets;     /* bins: irf_count pathlength offsets (length unit) */
  double *irf_samples;     /* bins: irf_count samples as given (the library normalises) */
  const cJSON *json;
  hetinv_pathlength_t *handle;
} scene_pathlength_t;

typedef struct scene_row {
  int emitter, sensor, pathlength; /* indices into the scene's arrays */
  char name[3 * SCENE_NAME_MAX + 8]; /* base name of its output files */
} scene_row_t;

typedef struct scene {
  const char *path;        /* the scene file */
  char dir[4096];          /* its folder: relative paths inside the scene start here */
  char *text;              /* the file's contents */
  cJSON *root;

  /* Run settings (command-line options override them). */
  int64_t photons;         /* per emitter */
  uint64_t seed;
  int32_t threads;         /* 0: all */
  int estimator_given[SCENE_ESTIMATOR_KEYS];   /* "estimator" members given, */
  double estimator_value[SCENE_ESTIMATOR_KEYS]; /* in the order of the docs */
  int has_noise;           /* "noise": a camera records the render (camera.h) */
  hetinv_noise_model_t noise;

  /* The medium. */
  char unit[32];           /* length unit, for the outputs' attributes */
  double eta, eta_out;
  double box_min[3], box_max[3];
  int32_t dims[3];
  const char *medium_kind; /* "uniform", "layers" or "vol" */
  hetinv_medium_t *medium;
  /* Set before scene_build by a program that needs only the grid, box and
   * η (hetinv-reconstruct reading measured files): .vol files are then
   * read for their header alone and every voxel holds placeholder values
   * (those of "uniform"/"layers"/"inclusions", 0 for a .vol parameter). */
  int geometry_only;

  scene_emitter_t *emitters;
  int emitter_count;
  scene_sensor_t *sensors;
  int sensor_count;
  scene_pathlength_t *pathlengths;
  int pathlength_count;
  scene_row_t *rows;
  int row_count;
  hetinv_measurements_t *set;
} scene_t;

/* Reads and parses the file and its run settings (photons, seed, threads,
 * estimator); creates no library object. On failure jr->message says why. */
int scene_load(scene_t *scene, const char *path, jr_t *jr);

/* scene_load on text already read (malloc'd; the scene owns it from now
 * on, also after a failure), as if from the file at path. */
int scene_load_text(scene_t *scene, const char *path, char *text, jr_t *jr);

/* Creates the medium, sampling functions and measurement set from ctx. */
int scene_build(scene_t *scene, hetinv_context_t *ctx, jr_t *jr);

/* Sets the estimator's photons (an error names photons_origin: "photons"
 * or "--photons") and the scene's "estimator" parameters. */
int scene_configure_estimator(const scene_t *scene, hetinv_estimator_t *estimator,
                              const char *photons_origin, jr_t *jr);

/* The EXR channel name of bin b of a row whose pathlength has `bins` bins:
 * "L" (steady state), "tau0000" ... ("tau00000" ... above 10000 bins, so
 * that the names sort in bin order). */
void scene_channel_name(const scene_pathlength_t *pl, int32_t b, char *out, size_t size);

/* Releases everything (the context must still exist); safe on a zeroed scene. */
void scene_destroy(scene_t *scene);

/* ---- shared by the scene_*.c files ---- */

/* Records "<file>: <path>: <library message> (<result name>)" and returns -1. */
int scene_lib_fail(jr_t *jr, const char *path, const hetinv_context_t *ctx, hetinv_result_t r);

/* Whether the scene set estimator.max_scattering itself. */
bool scene_max_scattering_given(const scene_t *sc);

/* Checks that name (at path) can be part of a file name: letters, digits,
 * '_', '-', '.', not starting with '.', shorter than max bytes. */
int scene_check_name(jr_t *jr, const char *path, const char *name, size_t max);

/* The in-face axes (u, v) of a face: (y, z), (x, z) or (x, y). */
void scene_face_axes(hetinv_face_t face, int *u, int *v);

/* Builds the medium from scene->root's "medium" (and "box", "eta", ...). */
int scene_build_medium(scene_t *scene, hetinv_context_t *ctx, jr_t *jr);

/* Builds emitters, sensors and pathlength windows. */
int scene_build_emitters(scene_t *scene, jr_t *jr);
int scene_build_sensors(scene_t *scene, jr_t *jr);
int scene_build_pathlengths(scene_t *scene, hetinv_context_t *ctx, jr_t *jr);

#endif
