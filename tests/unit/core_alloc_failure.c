/* Allocation failure, systematically: every scenario below (a medium and
 * the volume generators, every kind of emitter, sensor and pathlength
 * function (an IRF's too), a measurement set, renders and gradients (and a
 * loss with calibration gains) with one and two
 * threads, an optimizer run that writes a checkpoint and a second optimizer
 * that resumes it, layer-wise stages, EXR, .vol and PNG files) is first run once
 * through a counting allocator to learn its N allocations, then N more times
 * with allocation n failing, for every n in 1..N. Each time:
 *  - the call during which the allocation failed returns
 *    HETINV_ERROR_OUT_OF_MEMORY (not an I/O error, not success), every call
 *    before it succeeds, and the scenario stops there;
 *  - the caller's objects are as they were: a create function called with an
 *    output variable that already held an object sets the variable to NULL
 *    (as documented) and leaves that object alive and usable; a failing call
 *    on an existing object (add a row, read into a medium, fill a volume,
 *    add stages, resume an optimizer) leaves it unchanged; a failed
 *    optimizer run, run again, ends bitwise as the run that never failed;
 *  - a failing writer leaves neither the file nor a temporary file behind;
 *  - once everything is destroyed, every block the hooks handed out has come
 *    back to them, and nothing else was freed through them.
 * Only the allocations made through the context's hooks are counted: OpenEXR
 * and the OpenMP runtime use malloc. libpng is given the hooks, so its
 * allocations count too.
 *
 * Scenes are tiny (a few voxels, tens of photons, one thread) so that the
 * whole test runs in a few seconds under AddressSanitizer. Set
 * HETINV_ALLOC_TRACE=1 to print each scenario and n before it runs (to
 * name the n of a crash). */
#define _POSIX_C_SOURCE 200809L
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#include <dirent.h>

#include "test_support.h"

/* ------------------------------------------------------------------------ */
/* The counting allocator. Each block carries a header with a magic word, so
 * that a free of anything the hooks did not hand out (or a second free) is
 * caught even without a sanitizer. */

enum { HEADER = 16 };
static const uint64_t MAGIC = 0x68657469e5a110c8ULL, DEAD = 0xdeadbeefdeadbeefULL;

static struct {
  atomic_long count;    /* allocations requested through the hooks */
  atomic_long fail_at;  /* the allocation that returns NULL; 0: none */
  atomic_long failures; /* NULLs returned so far */
  atomic_long live;     /* blocks handed out and not yet freed */
  atomic_long bad_frees;
} H;

static void *hook_alloc(void *user, size_t size) {
  (void)user;
  long n = atomic_fetch_add(&H.count, 1) + 1;
  if (n == atomic_load(&H.fail_at)) {
    atomic_fetch_add(&H.failures, 1);
    return NULL;
  }
  unsigned char *p = malloc(HEADER + size);
  if (p == NULL) return NULL;
  memcpy(p, &MAGIC, sizeof MAGIC);
  atomic_fetch_add(&H.live, 1);
  return p + HEADER;
}

static void hook_free(void *user, void *ptr) {
  (void)user;
  unsigned char *p = (unsigned char *)ptr - HEADER;
  uint64_t magic;
  memcpy(&magic, p, sizeof magic);
  if (magic != MAGIC) {
    atomic_fetch_add(&H.bad_frees, 1);
    return;
  }
  memcpy(p, &DEAD, sizeof DEAD);
  atomic_fetch_sub(&H.live, 1);
  free(p);
}

static void hooks_reset(long fail_at) {
  atomic_store(&H.count, 0);
  atomic_store(&H.fail_at, fail_at);
  atomic_store(&H.failures, 0);
  atomic_store(&H.live, 0);
  atomic_store(&H.bad_frees, 0);
}

/* ------------------------------------------------------------------------ */
/* Steps. STEP runs a call of the scenario: it must succeed if no allocation
 * failed during it, and return HETINV_ERROR_OUT_OF_MEMORY (also recorded as
 * the thread's last error) if one did; after a failure the scenario jumps to
 * its label `failed`, where it checks the caller's objects and cleans up. */

static const char *current_scenario;
static long current_n;
/* Failed checks of the current scenario: counted rather than fatal, so that
 * one run reports every failing n (run_scenario fails at the end). */
static long check_failures;

static bool step(hetinv_result_t r, long failures_before, const char *call, int line) {
  bool injected = atomic_load(&H.failures) > failures_before;
  if (!injected && r == HETINV_SUCCESS) return true;
  if (injected && r == HETINV_ERROR_OUT_OF_MEMORY &&
      hetinv_context_last_error_code(NULL) == HETINV_ERROR_OUT_OF_MEMORY) {
    return false;
  }
  print_error("%s, allocation %ld failing: line %d: %s returned %s (%s allocation failed during "
              "it; message: %s)\n", current_scenario, current_n, line, call,
              hetinv_result_name(r), injected ? "an" : "no", hetinv_context_last_error_message(NULL));
  ++check_failures;
  return false;
}

/* Marks the end of a scenario's calls: what follows (checks, clean-up) is
 * not counted as an allocation point. */
static long allocations_at_end;
#define DONE \
  do { \
    done = true; \
    allocations_at_end = atomic_load(&H.count); \
  } while (0)

#define STEP(call) \
  do { \
    long failures_ = atomic_load(&H.failures); \
    if (!step((call), failures_, #call, __LINE__)) goto failed; \
  } while (0)

/* A check of the scenario's own: names the scenario and n on failure. */
#define CHECK(cond) \
  do { \
    if (!(cond)) { \
      print_error("%s, allocation %ld failing: line %d: %s is false\n", current_scenario, \
                  current_n, __LINE__, #cond); \
      ++check_failures; \
    } \
  } while (0)

static int32_t threads = 1; /* of the scenarios' contexts */

static hetinv_context_t *ctx_of_hooks(hetinv_result_t *r) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = hook_alloc;
  init.free_fn = hook_free;
  init.thread_count = threads;
  init.seed = 11;
  hetinv_context_t *ctx = (hetinv_context_t *)&init; /* must become NULL on failure */
  *r = hetinv_context_create(&init, &ctx);
  if (*r != HETINV_SUCCESS) CHECK(ctx == NULL);
  return ctx;
}

#define STEP_CONTEXT(ctx) \
  do { \
    hetinv_result_t rc_; \
    long failures_ = atomic_load(&H.failures); \
    (ctx) = ctx_of_hooks(&rc_); \
    if (!step(rc_, failures_, "hetinv_context_create", __LINE__)) goto failed; \
  } while (0)

/* A file of the scenario's directory must not exist (a failed writer). */
static bool exists(const char *path) { return access(path, F_OK) == 0; }

/* No temporary file of an atomic writer is left in the directory. */
static void check_no_temporaries(const char *dir) {
  DIR *d = opendir(dir);
  CHECK(d != NULL);
  if (d == NULL) return;
  for (struct dirent *e; (e = readdir(d)) != NULL;) {
    if (strstr(e->d_name, ".hetinv-tmp-") != NULL) {
      print_error("%s, allocation %ld failing: temporary file %s left behind\n", current_scenario,
                  current_n, e->d_name);
      ++check_failures;
    }
  }
  closedir(d);
}

/* ------------------------------------------------------------------------ */
/* A tiny scene shared by several scenarios: a 1 mm cube of 2 x 1 x 2 voxels,
 * η = 1.3, two pencil beams on z_min, an orthographic reflection sensor of
 * 2 x 1 pixels and a transmission detector, steady state. */

typedef struct scene {
  hetinv_medium_t *medium;
  hetinv_emitter_t *beams[2];
  hetinv_sensor_t *reflect, *transmit;
  hetinv_pathlength_t *steady;
  hetinv_measurements_t *set;
  hetinv_estimator_t *est;
} scene_t;

static hetinv_result_t scene_build(hetinv_context_t *ctx, scene_t *s) {
  hetinv_result_t r = hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1},
                                           (int32_t[]){2, 1, 2}, &s->medium);
  if (r == HETINV_SUCCESS) r = hetinv_medium_fill(s->medium, 0.2, 3.0, 0.3);
  if (r == HETINV_SUCCESS) r = hetinv_medium_set_ior(s->medium, 1.3, 1.0);
  if (r == HETINV_SUCCESS) r = hetinv_medium_set_voxel(s->medium, 1, 0, 1, 0.4, 5.0, 0.1);
  if (r == HETINV_SUCCESS) r = hetinv_medium_commit(s->medium);
  for (int e = 0; e < 2 && r == HETINV_SUCCESS; ++e) {
    r = hetinv_emitter_create_ideal(s->medium, (double[]){0.25 + 0.5 * e, 0.5, -1}, (double[]){0, 0, 1},
                                    &s->beams[e]);
  }
  if (r == HETINV_SUCCESS) {
    r = hetinv_sensor_create_orthographic(s->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                          (double[]){0, 0}, (double[]){0.5, 1}, 2, 1, &s->reflect);
  }
  if (r == HETINV_SUCCESS) {
    r = hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MAX, NULL, NULL, &s->transmit);
  }
  if (r == HETINV_SUCCESS) r = hetinv_pathlength_create_steady(ctx, &s->steady);
  if (r == HETINV_SUCCESS) r = hetinv_measurements_create(ctx, &s->set);
  for (int e = 0; e < 2 && r == HETINV_SUCCESS; ++e) {
    r = hetinv_measurements_add(s->set, s->beams[e], s->reflect, s->steady, NULL);
    if (r == HETINV_SUCCESS) r = hetinv_measurements_add(s->set, s->beams[e], s->transmit, s->steady, NULL);
  }
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &s->est);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, 40);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_BATCHES, 2);
  return r;
}

static void scene_release(scene_t *s) {
  hetinv_estimator_destroy(&s->est);
  hetinv_measurements_destroy(&s->set);
  for (int e = 0; e < 2; ++e) hetinv_emitter_destroy(&s->beams[e]);
  hetinv_sensor_destroy(&s->reflect);
  hetinv_sensor_destroy(&s->transmit);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_medium_destroy(&s->medium);
}

enum { SCENE_VALUES = 6 }; /* 2 beams x (2 reflection pixels + 1 transmission) */

/* ------------------------------------------------------------------------ */
/* Scenarios. Each returns true if it ran to its end. */

static const char *dir; /* the test's temporary directory */

/* A medium: create, fill, set, commit, clone (into a variable holding the
 * original), a Gaussian-mixture volume and a smoke volume. */
static bool scenario_medium(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  hetinv_medium_t *m = NULL, *orig = NULL, *copy = NULL, *vol = NULL, *smoke = NULL;
  const hetinv_medium_t *filling = NULL; /* the medium of a volume generator that failed */
  STEP_CONTEXT(ctx);
  STEP(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 2, 3}, (int32_t[]){3, 2, 2}, &m));
  STEP(hetinv_medium_fill(m, 0.5, 2.0, 0.2));
  STEP(hetinv_medium_set_voxel(m, 2, 1, 1, 0.7, 4.0, -0.3));
  STEP(hetinv_medium_set_ior(m, 1.4, 1.0));
  STEP(hetinv_medium_commit(m));
  orig = m;
  STEP(hetinv_medium_clone(orig, &m)); /* m held orig */
  copy = m;
  m = NULL;
  STEP(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){4, 4, 4}, &vol));
  hetinv_mixture_spec_t spec;
  hetinv_mixture_spec_default(&spec);
  filling = vol;
  STEP(hetinv_volume_gaussian_mixture(vol, &spec));
  filling = NULL;
  STEP(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){3, 3, 3}, &smoke));
  hetinv_smoke_spec_t smoke_spec;
  hetinv_smoke_spec_default(&smoke_spec);
  filling = smoke;
  STEP(hetinv_volume_smoke(smoke, &smoke_spec));
  filling = NULL;
  DONE;
failed:
  if (!done && orig != NULL && copy == NULL) {
    CHECK(m == NULL); /* the failed clone's output */
    double sa = 0, ss = 0, g = 0;
    CHECK(hetinv_medium_get_voxel(orig, 2, 1, 1, &sa, &ss, &g) == HETINV_SUCCESS);
    CHECK(sa == 0.7 && ss == 4.0 && g == -0.3);
  }
  if (filling != NULL) { /* a failed volume generator changes nothing */
    const double *ss = hetinv_medium_grid(filling, HETINV_PARAM_SIGMA_S);
    for (size_t i = 0; i < hetinv_medium_voxel_count(filling); ++i) CHECK(ss[i] == 0.0);
  }
  hetinv_medium_destroy(&smoke);
  if (m != orig && m != copy) hetinv_medium_destroy(&m);
  hetinv_medium_destroy(&orig);
  hetinv_medium_destroy(&copy);
  hetinv_medium_destroy(&vol);
  hetinv_context_destroy(&ctx);
  return done;
}

/* Every kind of emitter, sensor and pathlength function, each created a
 * second time into the variable that holds the first; a measurement set that
 * grows. */
static bool scenario_sampling(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  hetinv_medium_t *m = NULL;
  hetinv_emitter_t *kept[4] = {NULL}, *e = NULL;
  hetinv_sensor_t *skept[2] = {NULL}, *s = NULL;
  hetinv_pathlength_t *pkept[3] = {NULL}, *p = NULL;
  hetinv_measurements_t *set = NULL;
  int stage = 0; /* which handle the failed step was creating */
  int32_t rows_before = 0;
  size_t values_before = 0;
  STEP_CONTEXT(ctx);
  STEP(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){2, 2, 2}, &m));
  STEP(hetinv_medium_fill(m, 0.1, 1.0, 0.0));
  STEP(hetinv_medium_commit(m));

  const double o[6] = {0.3, 0.5, -1, 0.7, 0.5, -1}, d[6] = {0, 0, 1, 0, 0.2, 1}, w[2] = {1, 3};
  const double pattern[6] = {1, 2, 0, 4, 1, 1}, rmin[2] = {0.1, 0.1}, rmax[2] = {0.9, 0.8};
  for (int k = 0; k < 4; ++k) {
    for (int twice = 0; twice < 2; ++twice) {
      stage = 1 + k;
      e = kept[k]; /* the second time, the variable holds the first emitter */
      switch (k) {
        case 0: STEP(hetinv_emitter_create_ideal(m, o, d, &e)); break;
        case 1: STEP(hetinv_emitter_create_combination(m, 2, o, d, w, &e)); break;
        case 2:
          STEP(hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, (double[]){0, 0, 1}, rmin, rmax, 3, 2,
                                          pattern, &e));
          break;
        default: STEP(hetinv_emitter_create_diffuse(m, HETINV_FACE_X_MAX, (double[]){0.5, 0.5}, &e)); break;
      }
      if (twice == 0) {
        kept[k] = e;
      } else {
        hetinv_emitter_destroy(&e); /* the second one; the first stays in kept[k] */
      }
      e = NULL;
    }
  }
  for (int k = 0; k < 2; ++k) {
    for (int twice = 0; twice < 2; ++twice) {
      stage = 5 + k;
      s = skept[k];
      if (k == 0) {
        STEP(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                               (double[]){0, 0}, (double[]){0.5, 0.5}, 2, 2, &s));
      } else {
        STEP(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, rmin, rmax, &s));
      }
      if (twice == 0) skept[k] = s; else hetinv_sensor_destroy(&s);
      s = NULL;
    }
  }
  for (int k = 0; k < 3; ++k) {
    for (int twice = 0; twice < 2; ++twice) {
      stage = 7 + k;
      p = pkept[k];
      if (k == 0) {
        STEP(hetinv_pathlength_create_steady(ctx, &p));
      } else if (k == 1) {
        STEP(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_GAUSSIAN, 3, (double[]){2, 1, 3}, 0.5, &p));
      } else { /* through an instrument response (its taps are allocated too) */
        STEP(hetinv_pathlength_create_bins_irf(ctx, HETINV_WINDOW_BOX, 3, (double[]){2, 1, 3}, 1.0, 3,
                                               (double[]){-0.5, 0, 0.7}, (double[]){1, 0, 2}, &p));
      }
      if (twice == 0) pkept[k] = p; else hetinv_pathlength_destroy(&p);
      p = NULL;
    }
  }
  stage = 11;
  STEP(hetinv_measurements_create(ctx, &set));
  /* 2 emitters x 2 sensors x 2 pathlengths, and again: 16 rows, 96 values (grows both). */
  stage = 12;
  for (int round = 0; round < 2; ++round) {
    for (int k = 0; k < 4; ++k) {
      for (int j = 0; j < 2; ++j) {
        rows_before = hetinv_measurements_row_count(set);
        values_before = hetinv_measurements_value_count(set);
        STEP(hetinv_measurements_add(set, kept[k], skept[j], pkept[(k + j + round) % 2], NULL));
      }
    }
  }
  DONE;
failed:
  if (!done) {
    /* The failed create's output is NULL; the object it held is alive. */
    if (stage >= 1 && stage <= 4) CHECK(e == NULL);
    if (stage >= 5 && stage <= 6) CHECK(s == NULL);
    if (stage >= 7 && stage <= 9) CHECK(p == NULL);
    if (stage == 12) {
      CHECK(hetinv_measurements_row_count(set) == rows_before);
      CHECK(hetinv_measurements_value_count(set) == values_before);
    }
  }
  /* Every emitter and sensor kept is still usable (a freed one would be a
   * use after free here and a double free below). These allocations come
   * after the scenario's, so none of them is the one that fails. */
  if (m != NULL) {
    hetinv_measurements_t *probe = NULL;
    CHECK(hetinv_measurements_create(ctx, &probe) == HETINV_SUCCESS);
    for (int k = 0; k < 4; ++k) {
      for (int j = 0; j < 2; ++j) {
        if (kept[k] != NULL && skept[j] != NULL && pkept[0] != NULL) {
          CHECK(hetinv_measurements_add(probe, kept[k], skept[j], pkept[0], NULL) == HETINV_SUCCESS);
        }
      }
    }
    for (int j = 0; j < 2; ++j) {
      if (skept[j] != NULL) CHECK(hetinv_sensor_pixel_count(skept[j]) == (j == 0 ? 4 : 1));
    }
    for (int k = 0; k < 3; ++k) {
      if (pkept[k] != NULL) CHECK(hetinv_pathlength_bin_count(pkept[k]) == (k == 0 ? 1 : 3));
    }
    hetinv_measurements_destroy(&probe);
  }
  hetinv_measurements_destroy(&set);
  for (int k = 0; k < 4; ++k) hetinv_emitter_destroy(&kept[k]);
  for (int k = 0; k < 2; ++k) hetinv_sensor_destroy(&skept[k]);
  for (int k = 0; k < 3; ++k) hetinv_pathlength_destroy(&pkept[k]);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return done;
}

/* A render of the tiny scene, with standard errors and ballistic values;
 * then a pathlength-resolved render of an area, a diffuse and a combination
 * emitter. */
static bool scenario_render(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  scene_t sc = {0};
  double values[SCENE_VALUES], errors[SCENE_VALUES], ballistic[SCENE_VALUES];
  enum { TRANSIENT_VALUES = 3 * 2 * 4 }; /* 3 emitters x 2 pixels x 4 bins */
  double tvalues[TRANSIENT_VALUES], terrors[TRANSIENT_VALUES];
  hetinv_pathlength_t *bins = NULL;
  hetinv_emitter_t *more[3] = {NULL, NULL, NULL};
  hetinv_measurements_t *transient = NULL;
  STEP_CONTEXT(ctx);
  STEP(scene_build(ctx, &sc));
  STEP(hetinv_estimator_render(sc.est, sc.medium, sc.set, values, errors, ballistic, SCENE_VALUES));
  STEP(hetinv_estimator_render(sc.est, sc.medium, sc.set, values, NULL, NULL, SCENE_VALUES));
  /* Pathlength-resolved rows of an area, a diffuse and a combination emitter. */
  STEP(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 4, (double[]){0.5, 1.5, 2.5, 3.5}, 1.0, &bins));
  STEP(hetinv_emitter_create_area(sc.medium, HETINV_FACE_Z_MIN, (double[]){0, 0, 1}, (double[]){0.2, 0.2},
                                  (double[]){0.8, 0.8}, 2, 2, NULL, &more[0]));
  STEP(hetinv_emitter_create_diffuse(sc.medium, HETINV_FACE_X_MIN, (double[]){0.5, 0.5}, &more[1]));
  STEP(hetinv_emitter_create_combination(sc.medium, 2, (double[]){0.3, 0.5, -1, 0.6, 0.4, -1},
                                         (double[]){0, 0, 1, 0, 0, 1}, (double[]){1, 2}, &more[2]));
  STEP(hetinv_measurements_create(ctx, &transient));
  for (int k = 0; k < 3; ++k) STEP(hetinv_measurements_add(transient, more[k], sc.reflect, bins, NULL));
  STEP(hetinv_estimator_render(sc.est, sc.medium, transient, tvalues, terrors, NULL, TRANSIENT_VALUES));
  DONE;
failed:
  hetinv_measurements_destroy(&transient);
  for (int k = 0; k < 3; ++k) hetinv_emitter_destroy(&more[k]);
  hetinv_pathlength_destroy(&bins);
  scene_release(&sc);
  hetinv_context_destroy(&ctx);
  return done;
}

/* A render and a gradient whose sensors score exits only, on a uniform and
 * on a delta-tracked grid: the passes run in SIMD lanes (transport/lanes.h),
 * whose score logs wait in a ring and are allocated as paths grow. */
static bool scenario_lanes(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  hetinv_medium_t *medium[2] = {NULL, NULL};
  hetinv_emitter_t *beam[2] = {NULL, NULL};
  hetinv_sensor_t *transmit[2] = {NULL, NULL};
  hetinv_pathlength_t *steady = NULL;
  hetinv_measurements_t *set[2] = {NULL, NULL};
  hetinv_estimator_t *est = NULL;
  hetinv_param_map_t *ident[2] = {NULL, NULL};
  double value = 0, cot = 1, grad[3 * 8];
  STEP_CONTEXT(ctx);
  STEP(hetinv_pathlength_create_steady(ctx, &steady));
  STEP(hetinv_estimator_create(ctx, &est));
  STEP(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 60));
  STEP(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2));
  for (int v = 0; v < 2; ++v) { /* v = 1: every voxel different, delta tracking */
    STEP(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){2, 2, 2}, &medium[v]));
    STEP(hetinv_medium_fill(medium[v], 0.2, 8.0, 0.6));
    for (int32_t i = 0; v == 1 && i < 8; ++i) {
      STEP(hetinv_medium_set_voxel(medium[v], i % 2, (i / 2) % 2, i / 4, 0.2 + 0.05 * i, 8.0 - 0.5 * i, 0.6));
    }
    STEP(hetinv_medium_commit(medium[v]));
    STEP(hetinv_emitter_create_ideal(medium[v], (double[]){0.5, 0.5, -1}, (double[]){0, 0, 1}, &beam[v]));
    STEP(hetinv_sensor_create_hemispherical(medium[v], HETINV_FACE_Z_MAX, NULL, NULL, &transmit[v]));
    STEP(hetinv_measurements_create(ctx, &set[v]));
    STEP(hetinv_measurements_add(set[v], beam[v], transmit[v], steady, NULL));
    STEP(hetinv_param_map_create_identity(medium[v], HETINV_FREE_ALL, &ident[v]));
    STEP(hetinv_estimator_render(est, medium[v], set[v], &value, NULL, NULL, 1));
    STEP(hetinv_estimator_gradient(est, medium[v], set[v], &cot, 1, ident[v], grad, NULL, 3 * 8));
  }
  DONE;
failed:
  for (int v = 0; v < 2; ++v) {
    hetinv_param_map_destroy(&ident[v]);
    hetinv_measurements_destroy(&set[v]);
    hetinv_sensor_destroy(&transmit[v]);
    hetinv_emitter_destroy(&beam[v]);
    hetinv_medium_destroy(&medium[v]);
  }
  hetinv_estimator_destroy(&est);
  hetinv_pathlength_destroy(&steady);
  hetinv_context_destroy(&ctx);
  return done;
}

/* Gradients: of a cotangent and of the loss, per voxel and through a coarse
 * map. */
static bool scenario_gradient(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  scene_t sc = {0};
  hetinv_param_map_t *ident = NULL, *coarse = NULL, *bcast = NULL, *held = NULL;
  double cot[SCENE_VALUES] = {1, -1, 0.5, 2, 0, 1}, grad[12], gerr[12], loss = 0, rendered[SCENE_VALUES];
  STEP_CONTEXT(ctx);
  STEP(scene_build(ctx, &sc));
  STEP(hetinv_measurements_set_values(sc.set, cot, NULL, SCENE_VALUES));
  STEP(hetinv_param_map_create_identity(sc.medium, HETINV_FREE_ALL, &ident));
  STEP(hetinv_param_map_create_coarse(sc.medium, (int32_t[]){1, 1, 1}, HETINV_FREE_ALL, &coarse));
  held = coarse;
  STEP(hetinv_param_map_create_broadcast(sc.medium, 2, HETINV_FREE(HETINV_PARAM_SIGMA_S), &held));
  bcast = held;
  held = NULL;
  STEP(hetinv_estimator_gradient(sc.est, sc.medium, sc.set, cot, SCENE_VALUES, ident, grad, gerr, 12));
  STEP(hetinv_estimator_gradient(sc.est, sc.medium, sc.set, cot, SCENE_VALUES, coarse, grad, NULL, 3));
  STEP(hetinv_estimator_loss_gradient(sc.est, sc.medium, sc.set, bcast, &loss, rendered, grad, 2));
  /* with a calibration gain per emitter (the gains are allocated) */
  STEP(hetinv_estimator_set_gain_mode(sc.est, HETINV_GAIN_PER_EMITTER));
  STEP(hetinv_estimator_loss_gradient(sc.est, sc.medium, sc.set, bcast, &loss, rendered, grad, 2));
  DONE;
failed:
  if (!done && coarse != NULL && bcast == NULL) {
    CHECK(held == NULL);
    CHECK(hetinv_param_map_size(coarse) == 3);
  }
  hetinv_param_map_destroy(&ident);
  hetinv_param_map_destroy(&coarse);
  hetinv_param_map_destroy(&bcast);
  scene_release(&sc);
  hetinv_context_destroy(&ctx);
  return done;
}

/* Stops a run after `stop_after` iterations. */
static int stop_after(const hetinv_progress_t *progress, void *user) {
  return progress->iteration >= *(const int64_t *)user;
}

static hetinv_result_t configure(hetinv_optimizer_t *opt, hetinv_param_map_t *const maps[2],
                                 const char *checkpoint, const int64_t *stop) {
  hetinv_result_t r = hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 1.0, 10.0);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_AVERAGE_WINDOW, 2);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, 1);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, 100);
  for (int i = 0; i < 2 && r == HETINV_SUCCESS; ++i) {
    hetinv_stage_t st = {sizeof st, maps[i], 2, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
    r = hetinv_optimizer_add_stage(opt, &st);
  }
  if (r == HETINV_SUCCESS && checkpoint) r = hetinv_optimizer_set_checkpoint(opt, checkpoint);
  if (r == HETINV_SUCCESS && stop) r = hetinv_optimizer_set_progress(opt, stop_after, (void *)(uintptr_t)stop);
  return r;
}

/* The losses and final π (4 entries, the second stage's) of the run without
 * failure, which every run retried after a failure must reproduce bitwise. */
enum { RUN_ITERATIONS = 4, FINAL_K = 4 };
static double ref_losses[RUN_ITERATIONS], ref_pi[FINAL_K];

/* Runs @p opt to the end of its schedule (a failed run is retried by calling
 * run again, as after a stop) and compares it with the reference. */
static void check_finishes_as_reference(hetinv_optimizer_t *opt, hetinv_estimator_t *est) {
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  CHECK(hetinv_optimizer_set_checkpoint(opt, NULL) == HETINV_SUCCESS); /* fsyncs cost seconds */
  for (int tries = 0; tries < RUN_ITERATIONS + 1 && why != HETINV_STOP_COMPLETED; ++tries) {
    hetinv_result_t r = hetinv_optimizer_run(opt, est, &why);
    if (r != HETINV_SUCCESS) {
      print_error("%s, allocation %ld failing: the retried run returned %s (%s)\n", current_scenario,
                  current_n, hetinv_result_name(r), hetinv_context_last_error_message(NULL));
      ++check_failures;
      return;
    }
  }
  CHECK(why == HETINV_STOP_COMPLETED);
  size_t n = 0;
  const double *losses = hetinv_optimizer_losses(opt, &n);
  CHECK(n == RUN_ITERATIONS);
  for (size_t i = 0; i < n && i < RUN_ITERATIONS; ++i) CHECK(losses[i] == ref_losses[i]);
  double pi[FINAL_K];
  CHECK(hetinv_optimizer_get_pi(opt, 0, pi, FINAL_K) == HETINV_SUCCESS);
  for (int i = 0; i < FINAL_K; ++i) CHECK(pi[i] == ref_pi[i]);
}

/* A two-stage optimizer run (coarse, then per voxel; 2 iterations each)
 * stopped after 3 iterations (writing a checkpoint as it stops), its result, a
 * second optimizer that resumes the checkpoint and finishes, and an
 * explicit save. A failed run or resume, retried, must give the same
 * losses and π as the run that never failed. */
static bool scenario_optimizer(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  scene_t sc = {0};
  hetinv_param_map_t *maps[2] = {NULL, NULL};
  hetinv_optimizer_t *first = NULL, *second = NULL;
  hetinv_medium_t *result = NULL, *held = NULL;
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  const int64_t stop = 3;
  char checkpoint[1024], saved[1024];
  snprintf(checkpoint, sizeof checkpoint, "%s/run.ckpt", dir);
  snprintf(saved, sizeof saved, "%s/saved.ckpt", dir);
  enum { NOTHING, RUN_FIRST, RESUME, RUN_SECOND } failed_in = NOTHING;
  double values[SCENE_VALUES] = {0.02, 0.03, 0.1, 0.025, 0.02, 0.12};
  STEP_CONTEXT(ctx);
  STEP(scene_build(ctx, &sc));
  STEP(hetinv_estimator_set_param(sc.est, HETINV_ESTIMATOR_PHOTONS, 16));
  STEP(hetinv_measurements_set_values(sc.set, values, NULL, SCENE_VALUES));
  STEP(hetinv_param_map_create_coarse(sc.medium, (int32_t[]){1, 1, 1}, HETINV_FREE(HETINV_PARAM_SIGMA_S), &maps[0]));
  STEP(hetinv_param_map_create_identity(sc.medium, HETINV_FREE(HETINV_PARAM_SIGMA_S), &maps[1]));
  STEP(hetinv_optimizer_create(ctx, sc.set, sc.medium, &first));
  STEP(configure(first, maps, checkpoint, &stop));
  /* Created before the first run, so that fewer of the runs with a failure
   * write the checkpoint (its fsync costs more than the rest). */
  STEP(hetinv_optimizer_create(ctx, sc.set, sc.medium, &second));
  STEP(configure(second, maps, NULL, NULL));
  failed_in = RUN_FIRST;
  STEP(hetinv_optimizer_run(first, sc.est, &why));
  failed_in = NOTHING;
  CHECK(why == HETINV_STOP_CALLBACK);
  STEP(hetinv_optimizer_result(first, &result));
  held = result;
  STEP(hetinv_optimizer_result(first, &held));
  hetinv_medium_destroy(&held);
  failed_in = RESUME;
  STEP(hetinv_optimizer_resume(second, checkpoint));
  failed_in = RUN_SECOND;
  STEP(hetinv_optimizer_run(second, sc.est, &why));
  failed_in = NOTHING;
  CHECK(why == HETINV_STOP_COMPLETED);
  STEP(hetinv_optimizer_save(second, saved));
  DONE;
  if (current_n == 0) { /* the reference */
    size_t n = 0;
    const double *losses = hetinv_optimizer_losses(second, &n);
    CHECK(n == RUN_ITERATIONS);
    if (n == RUN_ITERATIONS) memcpy(ref_losses, losses, sizeof ref_losses);
    CHECK(hetinv_optimizer_get_pi(second, 0, ref_pi, FINAL_K) == HETINV_SUCCESS);
  }
failed:
  if (!done && result != NULL && held == NULL) {
    CHECK(hetinv_medium_is_committed(result)); /* the first result is intact */
  }
  if (failed_in == RUN_FIRST) check_finishes_as_reference(first, sc.est);
  if (failed_in == RESUME) { /* "On failure the optimizer is unchanged": not started */
    size_t n = 1;
    CHECK(hetinv_optimizer_losses(second, &n) == NULL && n == 0);
    CHECK(hetinv_optimizer_resume(second, checkpoint) == HETINV_SUCCESS);
  }
  if (failed_in == RESUME || failed_in == RUN_SECOND) check_finishes_as_reference(second, sc.est);
  if (!done) CHECK(!exists(saved));
  if (result != held) hetinv_medium_destroy(&held);
  hetinv_medium_destroy(&result);
  hetinv_optimizer_destroy(&second);
  hetinv_optimizer_destroy(&first);
  hetinv_param_map_destroy(&maps[0]);
  hetinv_param_map_destroy(&maps[1]);
  scene_release(&sc);
  hetinv_context_destroy(&ctx);
  return done;
}

/* Layer-wise stages on a frontlit pathlength-resolved set (the schedule is
 * all layers or none), a stage with frozen entries and a value mask, and a
 * short run through the stage changes. */
static bool scenario_layerwise(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  scene_t sc = {0};
  hetinv_pathlength_t *bins = NULL;
  hetinv_measurements_t *set = NULL;
  hetinv_param_map_t *map = NULL;
  hetinv_optimizer_t *opt = NULL;
  bool adding = false;
  enum { BINS = 4, VALUES = 2 * 2 * BINS };
  double values[VALUES];
  for (int i = 0; i < VALUES; ++i) values[i] = 0.01 * (i + 1);
  STEP_CONTEXT(ctx);
  STEP(scene_build(ctx, &sc));
  STEP(hetinv_estimator_set_param(sc.est, HETINV_ESTIMATOR_PHOTONS, 8));
  STEP(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, BINS, (double[]){0.5, 1.5, 2.5, 3.5}, 1.0, &bins));
  STEP(hetinv_measurements_create(ctx, &set));
  for (int e = 0; e < 2; ++e) STEP(hetinv_measurements_add(set, sc.beams[e], sc.reflect, bins, NULL));
  STEP(hetinv_measurements_set_values(set, values, NULL, VALUES));
  STEP(hetinv_param_map_create_identity(sc.medium, HETINV_FREE(HETINV_PARAM_SIGMA_S), &map));
  STEP(hetinv_optimizer_create(ctx, set, sc.medium, &opt));
  uint8_t frozen[4] = {0, 1, 0, 0}, mask[VALUES] = {0};
  for (int i = 0; i < VALUES; i += 2) mask[i] = 1;
  hetinv_stage_t st = {sizeof st, map, 1, frozen, mask, 0.0, 0, 0.0, 0.0, 0.0};
  STEP(hetinv_optimizer_add_stage(opt, &st));
  adding = true;
  STEP(hetinv_optimizer_add_layerwise_stages(opt, map, 0.5, 2, 1));
  adding = false;
  STEP(hetinv_optimizer_run(opt, sc.est, NULL));
  DONE;
failed:
  if (adding) { /* all layers or none: the schedule still has its one stage */
    CHECK(hetinv_optimizer_run(opt, sc.est, NULL) == HETINV_SUCCESS);
    size_t n = 0;
    hetinv_optimizer_losses(opt, &n);
    CHECK(n == 1);
  }
  hetinv_optimizer_destroy(&opt);
  hetinv_param_map_destroy(&map);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&bins);
  scene_release(&sc);
  hetinv_context_destroy(&ctx);
  return done;
}

/* An image with named channels and attributes, written as EXR and read back
 * into a variable that holds the original. */
static bool scenario_exr(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  hetinv_image_t *img = NULL, *back = NULL;
  char path[1024];
  snprintf(path, sizeof path, "%s/image.exr", dir);
  bool writing = false, reading = false;
  STEP_CONTEXT(ctx);
  STEP(hetinv_image_create(ctx, 5, 3, 3, &img));
  for (int c = 0; c < 3; ++c) {
    float *v = hetinv_image_channel_data(img, c);
    for (int i = 0; i < 15; ++i) v[i] = (float)(c * 100 + i);
  }
  STEP(hetinv_image_set_channel_name(img, 0, "sigma_s"));
  STEP(hetinv_image_set_channel_name(img, 2, "g"));
  STEP(hetinv_image_set_attribute_string(img, "hetinv:scene", "alloc failure"));
  STEP(hetinv_image_set_attribute_double(img, "hetinv:bin_width", 0.25));
  STEP(hetinv_image_set_attribute_int(img, "hetinv:bins", 16));
  STEP(hetinv_image_set_attribute_string(img, "hetinv:scene", "replaced"));
  writing = true;
  STEP(hetinv_image_write_exr(img, path));
  writing = false;
  back = img;
  reading = true;
  STEP(hetinv_image_read_exr(ctx, path, &back));
  reading = false;
  DONE;
failed:
  if (!done && writing) CHECK(!exists(path));
  if (reading) { /* the failed read's output is NULL; img is intact */
    CHECK(back == NULL);
    const char *value = NULL;
    CHECK(hetinv_image_get_attribute_string(img, "hetinv:scene", &value) == HETINV_SUCCESS);
    CHECK(value != NULL && strcmp(value, "replaced") == 0);
    CHECK(hetinv_image_channel_data(img, 2)[14] == 214.0f);
  }
  if (done) {
    int32_t ch = -1;
    CHECK(hetinv_image_find_channel(back, "g", &ch) == HETINV_SUCCESS);
  }
  if (back != img) hetinv_image_destroy(&back);
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  return done;
}

/* .vol files: raw write and read, a medium's parameter written and read back
 * into another medium. */
static bool scenario_vol(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  hetinv_medium_t *m = NULL, *target = NULL;
  char raw[1024], param[1024];
  snprintf(raw, sizeof raw, "%s/raw.vol", dir);
  snprintf(param, sizeof param, "%s/sigma_s.vol", dir);
  int writing = 0;
  bool reading = false;
  hetinv_vol_header_t h = {{2, 3, 1}, 1, {0, 0, 0}, {1, 1.5, 0.5}}, hb;
  float data[6] = {1, 2, 3, 4, 5, 6}, got[6];
  STEP_CONTEXT(ctx);
  writing = 1;
  STEP(hetinv_vol_write(ctx, raw, &h, data, 6));
  writing = 0;
  STEP(hetinv_vol_read_header(ctx, raw, &hb));
  STEP(hetinv_vol_read(ctx, raw, &hb, got, 6));
  STEP(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){2, 2, 2}, &m));
  STEP(hetinv_medium_fill(m, 0.1, 2.5, 0.2));
  STEP(hetinv_medium_set_voxel(m, 1, 1, 1, 0.1, 7.0, 0.2));
  writing = 2;
  STEP(hetinv_medium_write_vol(m, HETINV_PARAM_SIGMA_S, param));
  writing = 0;
  STEP(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){2, 2, 2}, &target));
  STEP(hetinv_medium_fill(target, 0.3, 1.0, 0.0));
  reading = true;
  STEP(hetinv_medium_read_vol(target, HETINV_PARAM_SIGMA_S, param));
  reading = false;
  DONE;
failed:
  if (writing) CHECK(!exists(writing == 1 ? raw : param));
  if (reading) { /* the medium is unchanged */
    const double *ss = hetinv_medium_grid(target, HETINV_PARAM_SIGMA_S);
    for (int i = 0; i < 8; ++i) CHECK(ss[i] == 1.0);
  }
  if (done) CHECK(hetinv_medium_grid(target, HETINV_PARAM_SIGMA_S)[7] == 7.0);
  hetinv_medium_destroy(&target);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return done;
}

/* PNG previews in both colour maps, one with an automatic range. */
static bool scenario_png(void) {
  bool done = false;
  hetinv_context_t *ctx = NULL;
  hetinv_image_t *img = NULL;
  char gray[1024], viridis[1024];
  snprintf(gray, sizeof gray, "%s/gray.png", dir);
  snprintf(viridis, sizeof viridis, "%s/viridis.png", dir);
  int writing = 0;
  STEP_CONTEXT(ctx);
  STEP(hetinv_image_create(ctx, 7, 4, 1, &img));
  float *v = hetinv_image_channel_data(img, 0);
  for (int i = 0; i < 28; ++i) v[i] = (float)i;
  writing = 1;
  STEP(hetinv_image_write_png(img, 0, gray, 0, 30, HETINV_COLORMAP_GRAY));
  writing = 2;
  STEP(hetinv_image_write_png(img, 0, viridis, 0, 0, HETINV_COLORMAP_VIRIDIS));
  writing = 0;
  DONE;
failed:
  if (writing) CHECK(!exists(writing == 1 ? gray : viridis));
  hetinv_image_destroy(&img);
  hetinv_context_destroy(&ctx);
  return done;
}

/* ------------------------------------------------------------------------ */
/* The driver. */

typedef bool (*scenario_fn)(void);

static double seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void run_scenario(const char *name, scenario_fn fn) {
  double t0 = seconds();
  const char *trace = getenv("HETINV_ALLOC_TRACE");
  current_scenario = name;
  current_n = 0;
  check_failures = 0;
  dir = ht_tmpdir_create(name);
  hooks_reset(0);
  if (trace) fprintf(stderr, "%s: counting\n", name);
  assert_true(fn());
  long total = allocations_at_end;
  assert_true(total > 0);
  CHECK(atomic_load(&H.live) == 0);
  CHECK(atomic_load(&H.bad_frees) == 0);
  check_no_temporaries(dir);
  ht_tmpdir_remove();
  for (long n = 1; n <= total; ++n) {
    current_n = n;
    dir = ht_tmpdir_create(name);
    if (trace) fprintf(stderr, "%s: allocation %ld of %ld fails\n", name, n, total);
    hooks_reset(n);
    bool completed = fn();
    CHECK(!completed);                        /* the failure stopped it */
    CHECK(atomic_load(&H.failures) == 1);     /* allocation n was reached */
    if (atomic_load(&H.live) != 0) {
      print_error("%s, allocation %ld failing: %ld blocks leaked\n", name, n, (long)atomic_load(&H.live));
      ++check_failures;
    }
    CHECK(atomic_load(&H.bad_frees) == 0);
    check_no_temporaries(dir);
    ht_tmpdir_remove();
  }
  print_message("%s: %ld allocation points, each failed once (%.1f s)\n", name, total, seconds() - t0);
  assert_int_equal(check_failures, 0);
}

static void medium_calls_fail_cleanly(void **state) {
  (void)state;
  run_scenario("medium", scenario_medium);
}

static void sampling_calls_fail_cleanly(void **state) {
  (void)state;
  run_scenario("sampling", scenario_sampling);
}

static void a_render_fails_cleanly(void **state) {
  (void)state;
  run_scenario("render", scenario_render);
}

static void gradients_fail_cleanly(void **state) {
  (void)state;
  run_scenario("gradient", scenario_gradient);
}

static void passes_in_lanes_fail_cleanly(void **state) {
  (void)state;
  run_scenario("lanes", scenario_lanes);
}

static void an_optimizer_run_and_resume_fail_cleanly(void **state) {
  (void)state;
  run_scenario("optimizer", scenario_optimizer);
}

static void layerwise_stages_fail_cleanly(void **state) {
  (void)state;
  run_scenario("layerwise", scenario_layerwise);
}

/* The per-thread buffers of the estimator's passes. */
static void two_thread_passes_fail_cleanly(void **state) {
  (void)state;
  threads = 2;
  run_scenario("render-2-threads", scenario_render);
  run_scenario("gradient-2-threads", scenario_gradient);
  threads = 1;
}

static void exr_io_fails_cleanly(void **state) {
  (void)state;
  run_scenario("exr", scenario_exr);
}

static void vol_io_fails_cleanly(void **state) {
  (void)state;
  run_scenario("vol", scenario_vol);
}

static void png_writes_fail_cleanly(void **state) {
  (void)state;
  run_scenario("png", scenario_png);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(medium_calls_fail_cleanly),
      cmocka_unit_test(sampling_calls_fail_cleanly),
      cmocka_unit_test(a_render_fails_cleanly),
      cmocka_unit_test(gradients_fail_cleanly),
      cmocka_unit_test(passes_in_lanes_fail_cleanly),
      cmocka_unit_test(an_optimizer_run_and_resume_fail_cleanly),
      cmocka_unit_test(layerwise_stages_fail_cleanly),
      cmocka_unit_test(two_thread_passes_fail_cleanly),
      cmocka_unit_test(exr_io_fails_cleanly),
      cmocka_unit_test(vol_io_fails_cleanly),
      cmocka_unit_test(png_writes_fail_cleanly),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
