/* The optimizer tests' shared problem (tests/unit/optimize_*.c): a 1 mm
 * cube of 2 x 1 x 2 (or 3 x 1 x 3) voxels, η = 1.3, a few pencil beams and
 * small orthographic sensors, a few hundred photons per emitter, so every
 * test runs in a fraction of a second under ASan; optimizer configurations
 * built on it, and what a run leaves, to compare runs bitwise. The contexts
 * use one thread: the checkpoint tests fork(), and an OpenMP runtime that
 * has started worker threads is not fork-safe. */
#ifndef HETINV_TESTS_OPTIMIZE_PROBLEM_H
#define HETINV_TESTS_OPTIMIZE_PROBLEM_H

#include <math.h>
#include <stdbool.h>

#include "test_support.h"

#include "optimize/optimizer_internal.h"

#define SS HETINV_FREE(HETINV_PARAM_SIGMA_S)
#define NaN ((double)NAN)
#define Inf ((double)INFINITY)

/* |a - b| <= tol, printing both on failure. */
#define assert_close(a, b, tol) \
  do { \
    double a_ = (a), b_ = (b); \
    if (!(fabs(a_ - b_) <= (tol))) { \
      print_error("%s = %.17g, expected %s = %.17g (tolerance %g)\n", #a, a_, #b, b_, (double)(tol)); \
      fail(); \
    } \
  } while (0)

enum { MAX_EMITTERS = 4, MAX_K = 16, MAX_LOSSES = 256, MAX_VOXELS = 16 };

static const double TRUTH_SIGMA_A = 0.2, TRUTH_SIGMA_S = 3.0, START_SIGMA_S = 8.0;
static const double SIGMA_LO = 1.0, SIGMA_HI = 10.0; /* the paper's box */

/* ------------------------------------------------------------------------ */
/* A tiny problem: a uniform (or, for layer-wise tests, layered) medium, pencil
 * beams entering face Z_MIN along +z, an orthographic reflection sensor on
 * Z_MIN and a transmission sensor on Z_MAX (2 x 1 pixels each). With
 * `bins`, the rows are reflection only and resolved in pathlength (16 box
 * bins of 0.25 mm): the frontlit set of the layer-wise procedure. */

typedef struct problem {
  hetinv_context_t *ctx;
  int32_t dims[3];
  int emitters;
  hetinv_medium_t *truth, *initial;
  hetinv_emitter_t *beams[MAX_EMITTERS];
  double beam_x[MAX_EMITTERS];
  hetinv_sensor_t *reflect, *transmit;
  hetinv_pathlength_t *pathlength;
  hetinv_measurements_t *set;
  hetinv_estimator_t *est;
  hetinv_param_map_t *coarse, *identity; /* σs free: 1 x 1 x 1, and per voxel */
  size_t count;
} problem_t;

enum { BINS = 16 };
static const double BIN_WIDTH = 0.25;

/* ------------------------------------------------------------------------ */
/* Optimizer configurations. Built without cmocka asserts (they return the
 * first failure), so that the tests can check them. */

typedef struct setup {
  int stages;
  const hetinv_param_map_t *maps[2];
  int32_t iterations[2];
  double method, minibatch, window, interval;
  double epsilon_start[2]; /* each stage's ε at its start; 0 = the tunable */
  int32_t stage_window[2];  /* each stage's averaging window; 0 = the tunable */
  double settle_epsilon[2], settle_fraction[2]; /* each stage's settling part; 0 = none */
  double settle_photons[2];                      /* its photons, × the estimator's; 0 = none */
} setup_t;

/* Everything a run leaves: π (last and averaged), losses, the result medium. */
typedef struct outcome {
  size_t k, loss_count, voxels;
  double pi[MAX_K], avg[MAX_K];
  double losses[MAX_LOSSES];
  double grid[HETINV_PARAM_COUNT][MAX_VOXELS];
} outcome_t;

/* Records π (last and averaged) and the progress after every iteration. */
typedef struct pi_log {
  const hetinv_optimizer_t *opt;
  int count;
  double pi[MAX_LOSSES][MAX_K], avg[MAX_LOSSES][MAX_K];
  hetinv_progress_t progress[MAX_LOSSES];
} pi_log_t;

/* Counts progress calls, keeps the last, stops after iteration stop_at. */
typedef struct stopper {
  int64_t stop_at;
  int calls;
  hetinv_progress_t last;
} stopper_t;

hetinv_context_t *make_context(uint64_t seed);
hetinv_medium_t *make_medium(hetinv_context_t *ctx, const int32_t dims[3], double sigma_s);
void problem_init(problem_t *p, uint64_t seed, int32_t nx, int32_t nz, int emitters, bool bins);
void problem_release(problem_t *p);
/* The default problem of most tests, as cmocka's group set-up and teardown:
 * 2 x 1 x 2 voxels, two beams, steady. */
int problem_setup(void **state);
int problem_teardown(void **state);

/* One coarse stage of 8 iterations, ADADELTA, every emitter, window 3. */
setup_t coarse_setup(const problem_t *p);
/* Coarse (4 iterations) then per voxel (4 iterations). */
setup_t two_stage_setup(const problem_t *p);
/* Applies s to opt; the first failure, without cmocka asserts. */
hetinv_result_t configure(hetinv_optimizer_t *opt, const setup_t *s);
hetinv_optimizer_t *make_optimizer(const problem_t *p, const setup_t *s);
void capture(const hetinv_optimizer_t *opt, size_t k, outcome_t *o);
void assert_same_outcome(const outcome_t *a, const outcome_t *b);
/* Runs a configuration to its end from scratch and captures it. */
void reference_run(const problem_t *p, const setup_t *s, size_t k, outcome_t *o);
double mean_sigma_s(const hetinv_medium_t *m);
/* Progress callbacks: user is a pi_log_t, a stopper_t. */
int log_pi(const hetinv_progress_t *progress, void *user);
int stop_at(const hetinv_progress_t *progress, void *user);

#endif
