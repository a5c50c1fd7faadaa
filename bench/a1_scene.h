/* The anchor medium A1 of the benchmarks, and its variants: one context
 * with everything a render needs (shared by hetinv-bench-forward and
 * hetinv-bench-gradient).
 *
 * A1: σa = 1/mm, σs = 10/mm, g = 0.5, a 10 mm cube as 100³ voxels of
 * 0.1 mm, a pencil beam at the centre of the top face (z = z_max) pointing
 * inward, Russian roulette below weight 1e-4 surviving one in ten. Rd is
 * the power leaving through the whole top face (a hemispherical detector).
 *   a1      η = η_out = 1 (index matched)     reference Rd 0.2950
 *   a1-eta  η = 1.37 in air (η_out = 1)       reference Rd 0.1719, specular 0.0244
 *   a1-het  A1 with σa and σs of every voxel multiplied by independent
 *           factors uniform in [0.5, 1.5] (fixed seed); no reference. */
#ifndef HETINV_BENCH_A1_SCENE_H
#define HETINV_BENCH_A1_SCENE_H

#include <stdbool.h>
#include <stdint.h>
#include <time.h>

#include "hetinv/hetinv.h"

typedef enum { CASE_A1, CASE_A1_ETA, CASE_A1_HET, CASE_COUNT } case_id_t;

typedef struct bench_case {
  const char *name;
  double eta;
  bool het;
  double ref_rd;       /* < 0: no reference */
  double ref_specular; /* < 0: none quoted */
} bench_case_t;

extern const bench_case_t cases[CASE_COUNT];

/* One context with everything a render needs. */
typedef struct scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *emitter;
  hetinv_sensor_t *sensor;
  hetinv_pathlength_t *steady;
  hetinv_measurements_t *set;
  hetinv_estimator_t *est;
} scene_t;

/* Prints the library's message and returns false unless r is success. */
bool check(hetinv_result_t r, const hetinv_context_t *ctx, const char *what);
double clock_seconds(clockid_t id);
bool scene_create(case_id_t c, int32_t threads, double photons, scene_t *s);
void scene_destroy(scene_t *s);
/* Parses an integer in [lo, hi]. */
bool parse_number(const char *s, double lo, double hi, double *out);
/* Index of the case called name, or -1. */
int find_case(const char *name);

#endif
