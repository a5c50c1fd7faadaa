#include "a1_scene.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define A1_N 100
#define A1_SIZE 10.0
#define A1_SIGMA_A 1.0
#define A1_SIGMA_S 10.0
#define A1_G 0.5
#define ROULETTE_WEIGHT 1e-4
#define ROULETTE_SURVIVAL 0.1
#define HET_SEED UINT64_C(0x5eed0a1)

const bench_case_t cases[CASE_COUNT] = {
    [CASE_A1] = {"a1", 1.0, false, 0.2950, -1.0},
    [CASE_A1_ETA] = {"a1-eta", 1.37, false, 0.1719, 0.0244},
    [CASE_A1_HET] = {"a1-het", 1.0, true, -1.0, -1.0},
};


bool check(hetinv_result_t r, const hetinv_context_t *ctx, const char *what) {
  if (r == HETINV_SUCCESS) return true;
  fprintf(stderr, "hetinv-bench: %s failed: %s (%s)\n", what, hetinv_result_name(r),
          hetinv_context_last_error_message(ctx));
  return false;
}

double clock_seconds(clockid_t id) {
  struct timespec ts;
  clock_gettime(id, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* splitmix64: the het variant's voxel factors, reproducible everywhere. */
static uint64_t splitmix64(uint64_t *state) {
  uint64_t z = (*state += UINT64_C(0x9e3779b97f4a7c15));
  z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
  z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
  return z ^ (z >> 31);
}

static double factor(uint64_t *state) {
  return 0.5 + (double)(splitmix64(state) >> 11) * 0x1p-53; /* [0.5, 1.5) */
}

/* σa and σs of the het variant in linear voxel order (x fastest). */
static bool fill_het(hetinv_medium_t *m, hetinv_context_t *ctx) {
  size_t n = hetinv_medium_voxel_count(m);
  double *sa = malloc(n * sizeof *sa), *ss = malloc(n * sizeof *ss);
  bool ok = sa && ss;
  if (!ok) fprintf(stderr, "hetinv-bench: out of memory\n");
  uint64_t state = HET_SEED;
  for (size_t i = 0; ok && i < n; ++i) {
    sa[i] = A1_SIGMA_A * factor(&state);
    ss[i] = A1_SIGMA_S * factor(&state);
  }
  ok = ok &&
       check(hetinv_medium_set_grid(m, HETINV_PARAM_SIGMA_A, sa, n), ctx, "set_grid sigma_a") &&
       check(hetinv_medium_set_grid(m, HETINV_PARAM_SIGMA_S, ss, n), ctx, "set_grid sigma_s");
  free(sa);
  free(ss);
  return ok;
}

void scene_destroy(scene_t *s) {
  hetinv_estimator_destroy(&s->est);
  hetinv_measurements_destroy(&s->set);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_sensor_destroy(&s->sensor);
  hetinv_emitter_destroy(&s->emitter);
  hetinv_medium_destroy(&s->medium);
  hetinv_context_destroy(&s->ctx);
}

bool scene_create(case_id_t c, int32_t threads, double photons, scene_t *s) {
  *s = (scene_t){0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = threads;
  init.seed = 0;
  if (!check(hetinv_context_create(&init, &s->ctx), NULL, "context_create")) return false;
  hetinv_context_t *ctx = s->ctx;
  const double lo[3] = {0.0, 0.0, 0.0}, hi[3] = {A1_SIZE, A1_SIZE, A1_SIZE};
  const int32_t dims[3] = {A1_N, A1_N, A1_N};
  const double origin[3] = {0.5 * A1_SIZE, 0.5 * A1_SIZE, A1_SIZE}, down[3] = {0.0, 0.0, -1.0};
  bool ok =
      check(hetinv_medium_create(ctx, lo, hi, dims, &s->medium), ctx, "medium_create") &&
      check(hetinv_medium_set_ior(s->medium, cases[c].eta, 1.0), ctx, "medium_set_ior") &&
      check(hetinv_medium_fill(s->medium, A1_SIGMA_A, A1_SIGMA_S, A1_G), ctx, "medium_fill") &&
      (!cases[c].het || fill_het(s->medium, ctx)) &&
      check(hetinv_medium_commit(s->medium), ctx, "medium_commit") &&
      check(hetinv_emitter_create_ideal(s->medium, origin, down, &s->emitter), ctx,
            "emitter_create_ideal") &&
      check(
          hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MAX, NULL, NULL, &s->sensor),
          ctx, "sensor_create_hemispherical") &&
      check(hetinv_pathlength_create_steady(ctx, &s->steady), ctx, "pathlength_create_steady") &&
      check(hetinv_measurements_create(ctx, &s->set), ctx, "measurements_create") &&
      check(hetinv_measurements_add(s->set, s->emitter, s->sensor, s->steady, NULL), ctx,
            "measurements_add") &&
      check(hetinv_estimator_create(ctx, &s->est), ctx, "estimator_create") &&
      check(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, photons), ctx,
            "set_param PHOTONS") &&
      check(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_ROULETTE_WEIGHT, ROULETTE_WEIGHT),
            ctx, "set_param ROULETTE_WEIGHT") &&
      check(
          hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_ROULETTE_SURVIVAL, ROULETTE_SURVIVAL),
          ctx, "set_param ROULETTE_SURVIVAL");
  if (!ok) scene_destroy(s);
  return ok;
}

bool parse_number(const char *s, double lo, double hi, double *out) {
  char *end;
  errno = 0;
  double v = strtod(s, &end);
  if (errno != 0 || end == s || *end != '\0' || !(v >= lo && v <= hi) || v != floor(v))
    return false;
  *out = v;
  return true;
}

int find_case(const char *name) {
  for (int c = 0; c < CASE_COUNT; ++c) {
    if (strcmp(name, cases[c].name) == 0) return c;
  }
  return -1;
}
