/* Failures under MPI (run under mpirun with 2 ranks): whatever fails on
 * one rank alone, or differs between the ranks, every rank returns the
 * same error, and none waits forever for another (the test's TIMEOUT is
 * the hang detector). Each case's bad input goes to the last rank. */
#define _POSIX_C_SOURCE 200809L /* nanosleep */
#include <hetinv/mpi.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "test_support.h"

enum { PHOTONS = 400 };

/* Allocations fail from the armed count on (this rank only). */
static long fail_in = -1;
static void *counting_alloc(void *user, size_t size) {
  (void)user;
  if (fail_in == 0) return NULL;
  if (fail_in > 0) --fail_in;
  return malloc(size);
}
static void counting_free(void *user, void *ptr) {
  (void)user;
  free(ptr);
}

typedef struct scene {
  int rank, last;
  hetinv_context_t *ctx;
  hetinv_medium_t *medium, *other; /* other: σa 3× on every rank */
  hetinv_emitter_t *beam[3];
  hetinv_sensor_t *hemi;
  hetinv_pathlength_t *steady;
  hetinv_measurements_t *set;
  hetinv_param_map_t *map;
  hetinv_estimator_t *est;
  size_t count, k;
} scene_t;

/* A 2 × 1 × 2 medium, three beams (so both ranks trace), a hemispherical
 * detector on the far face. */
static int setup(void **state) {
  scene_t *s = calloc(1, sizeof *s);
  MPI_Comm_rank(MPI_COMM_WORLD, &s->rank);
  MPI_Comm_size(MPI_COMM_WORLD, &s->last);
  s->last -= 1;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  init.seed = 5;
  init.alloc_fn = counting_alloc;
  init.free_fn = counting_free;
  assert_ok(hetinv_context_create(&init, &s->ctx));
  const double lo[3] = {0, 0, 0}, hi[3] = {2, 1, 2};
  for (int m = 0; m < 2; ++m) {
    hetinv_medium_t **medium = m == 0 ? &s->medium : &s->other;
    assert_ok(hetinv_medium_create(s->ctx, lo, hi, (int32_t[]){2, 1, 2}, medium));
    assert_ok(hetinv_medium_fill(*medium, m == 0 ? 0.1 : 0.3, 1.0, 0.2));
    assert_ok(hetinv_medium_commit(*medium));
  }
  for (int e = 0; e < 3; ++e) {
    assert_ok(hetinv_emitter_create_ideal(s->medium, (double[]){0.5 + 0.5 * e, 0.5, -1}, (double[]){0, 0, 1},
                                          &s->beam[e]));
  }
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MAX, NULL, NULL, &s->hemi));
  assert_ok(hetinv_pathlength_create_steady(s->ctx, &s->steady));
  assert_ok(hetinv_measurements_create(s->ctx, &s->set));
  for (int e = 0; e < 3; ++e) assert_ok(hetinv_measurements_add(s->set, s->beam[e], s->hemi, s->steady, NULL));
  s->count = hetinv_measurements_value_count(s->set);
  assert_ok(hetinv_estimator_create(s->ctx, &s->est));
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, PHOTONS));
  double values[3];
  assert_ok(hetinv_estimator_render(s->est, s->medium, s->set, values, NULL, NULL, s->count));
  assert_ok(hetinv_measurements_set_values(s->set, values, NULL, s->count));
  assert_ok(hetinv_param_map_create_identity(s->medium, HETINV_FREE(HETINV_PARAM_SIGMA_S), &s->map));
  s->k = hetinv_param_map_size(s->map);
  *state = s;
  return 0;
}

static int teardown(void **state) {
  scene_t *s = *state;
  hetinv_param_map_destroy(&s->map);
  hetinv_estimator_destroy(&s->est);
  hetinv_measurements_destroy(&s->set);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_sensor_destroy(&s->hemi);
  for (int e = 0; e < 3; ++e) hetinv_emitter_destroy(&s->beam[e]);
  hetinv_medium_destroy(&s->medium);
  hetinv_medium_destroy(&s->other);
  hetinv_context_destroy(&s->ctx);
  free(s);
  return 0;
}

/* The failing rank keeps its own message; the others record a copy of it
 * under the same function's name, and every rank reports the failing rank,
 * so that a program prints the failure once. */
static void expect_named(const scene_t *s, hetinv_result_t want, hetinv_result_t got, const char *func,
                         const char *own) {
  assert_int_equal(got, want);
  assert_message_contains(own);
  char prefix[256];
  snprintf(prefix, sizeof prefix, "%s: %s", func, s->rank == s->last ? "" : "rank 1 of 2: ");
  const char *m = hetinv_context_last_error_message(s->ctx);
  assert_true(strncmp(m, prefix, strlen(prefix)) == 0);
  assert_null(strstr(m + strlen(prefix), func)); /* the name once */
  assert_int_equal(hetinv_context_last_error_rank(s->ctx), s->last);
}

/* A program's own status: the others learn the rank and code, not a text
 * (the failing rank's last library message may be an older failure's). */
static void agree_names_the_failing_rank(void **state) {
  scene_t *s = *state;
  double values[3];
  if (s->rank == s->last) {
    /* a stale library message of the same code on the failing rank */
    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    int32_t n[3] = {1, 1, 1};
    assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_create(s->ctx, lo, hi, n, NULL));
  }
  hetinv_result_t mine = s->rank == s->last ? HETINV_ERROR_NULL_ARGUMENT : HETINV_SUCCESS;
  assert_int_equal(hetinv_context_agree(s->ctx, mine), HETINV_ERROR_NULL_ARGUMENT);
  if (s->rank != s->last) {
    assert_message_contains("rank 1 of 2 failed with HETINV_ERROR_NULL_ARGUMENT");
    assert_int_equal(hetinv_context_last_error_rank(s->ctx), s->last);
  }
  assert_ok(hetinv_context_agree(s->ctx, HETINV_SUCCESS));
  assert_ok(hetinv_estimator_render(s->est, s->medium, s->set, values, NULL, NULL, s->count));
}

/* A NULL output on one rank: that rank used to return at once and leave
 * the other in the render's gather. */
static void a_bad_argument_on_one_rank_fails_every_rank(void **state) {
  scene_t *s = *state;
  double values[3];
  double *out = s->rank == s->last ? NULL : values;
  expect_named(s, HETINV_ERROR_NULL_ARGUMENT,
               hetinv_estimator_render(s->est, s->medium, s->set, out, NULL, NULL, s->count),
               "hetinv_estimator_render", "'values' is NULL");
  double grad[4];
  double cot[3] = {1, 1, s->rank == s->last ? NAN : 1};
  expect_named(s, HETINV_ERROR_INVALID_ARGUMENT,
               hetinv_estimator_gradient(s->est, s->medium, s->set, cot, s->count, s->map, grad, NULL, s->k),
               "hetinv_estimator_gradient", "cotangent[2] is nan");
  /* The next calls work. */
  assert_ok(hetinv_estimator_render(s->est, s->medium, s->set, values, NULL, NULL, s->count));
}

/* Ranks given other photons, another medium, other measured values: they
 * used to return values that differ per rank or mix the two. */
static void arguments_that_differ_are_refused(void **state) {
  scene_t *s = *state;
  double values[3], grad[4], loss = 0;
  const char *differ = "the 2 ranks' calls differ";
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, s->rank == s->last ? 2 * PHOTONS : PHOTONS));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(s->est, s->medium, s->set, values, NULL, NULL, s->count));
  assert_message_contains(differ);
  assert_int_equal(hetinv_context_last_error_rank(s->ctx), 0); /* found by all: printed by rank 0 */
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, PHOTONS));
  const hetinv_medium_t *m = s->rank == s->last ? s->other : s->medium;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_estimator_render(s->est, m, s->set, values, NULL, NULL, s->count));
  assert_message_contains(differ);
  double cot[3] = {1, 1, s->rank == s->last ? 2 : 1};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_gradient(s->est, s->medium, s->set, cot, s->count, s->map, grad, NULL, s->k));
  assert_message_contains(differ);
  /* Measured values that differ: the loss would mix them. */
  double measured[3];
  memcpy(measured, hetinv_measurements_values(s->set), sizeof measured);
  double moved[3] = {measured[0], measured[1], measured[2] * (s->rank == s->last ? 2 : 1)};
  assert_ok(hetinv_measurements_set_values(s->set, moved, NULL, s->count));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_estimator_loss_gradient(s->est, s->medium, s->set, s->map, &loss, NULL, grad, s->k));
  assert_message_contains(differ);
  assert_ok(hetinv_measurements_set_values(s->set, measured, NULL, s->count));
  assert_ok(hetinv_estimator_loss_gradient(s->est, s->medium, s->set, s->map, &loss, NULL, grad, s->k));
}

/* Out of memory on one rank while the pass is built (the tracking grid,
 * the plans, the loss gradient's buffers), before any collective. */
static void out_of_memory_on_one_rank_fails_every_rank(void **state) {
  scene_t *s = *state;
  double values[3], grad[4], loss = 0;
  for (long first = 0; first < 4; ++first) {
    fail_in = s->rank == s->last ? first : -1;
    hetinv_result_t r = hetinv_estimator_render(s->est, s->medium, s->set, values, NULL, NULL, s->count);
    fail_in = -1;
    assert_int_equal(r, HETINV_ERROR_OUT_OF_MEMORY);
    fail_in = s->rank == s->last ? first : -1;
    r = hetinv_estimator_loss_gradient(s->est, s->medium, s->set, s->map, &loss, NULL, grad, s->k);
    fail_in = -1;
    assert_int_equal(r, HETINV_ERROR_OUT_OF_MEMORY);
  }
  assert_ok(hetinv_estimator_render(s->est, s->medium, s->set, values, NULL, NULL, s->count));
}

static hetinv_optimizer_t *optimizer(const scene_t *s, int32_t iterations) {
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(s->ctx, s->set, s->other, &opt));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, 2));
  hetinv_stage_t st = {sizeof st, s->map, iterations, NULL, NULL, 0, 0, 0, 0, 0};
  assert_ok(hetinv_optimizer_add_stage(opt, &st));
  return opt;
}

/* Rank 0 writes the checkpoint: where it cannot, every rank fails (the
 * others used to go on into the next iteration's gather). */
static void a_checkpoint_rank_0_cannot_write_fails_every_rank(void **state) {
  scene_t *s = *state;
  hetinv_optimizer_t *opt = optimizer(s, 20);
  ht_tmpdir_create("mpi-checkpoint");
  char path[1024];
  snprintf(path, sizeof path, "%s", ht_path("no-such-folder/run.ckpt"));
  assert_ok(hetinv_optimizer_set_checkpoint(opt, path));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, 5));
  hetinv_result_t r = hetinv_optimizer_run(opt, s->est, NULL);
  assert_int_equal(r, HETINV_ERROR_IO);
  assert_int_equal(hetinv_context_last_error_rank(s->ctx), 0);
  if (s->rank != 0) assert_message_contains("hetinv_optimizer_run: rank 0 of 2: ");
  assert_message_contains("run.ckpt");
  hetinv_optimizer_destroy(&opt);
  ht_tmpdir_remove(); /* each rank made its own */
}

/* A schedule of 3 + rank iterations: rank 0 left the loop while rank 1
 * waited in its fourth iteration's collectives, and a program's agreement
 * after the run paired with one inside that iteration (both had key 0);
 * then every rank hung. Now the run refuses to start, on every rank. */
static void schedules_that_differ_are_refused_before_the_run(void **state) {
  scene_t *s = *state;
  hetinv_optimizer_t *opt = optimizer(s, 3 + s->rank);
  hetinv_result_t r = hetinv_optimizer_run(opt, s->est, NULL);
  assert_int_equal(r, HETINV_ERROR_INVALID_ARGUMENT);
  assert_message_contains("hetinv_optimizer_run: the 2 ranks' calls differ in the optimizer's tunables, stages or progress");
  assert_ok(hetinv_context_agree(s->ctx, HETINV_SUCCESS)); /* and the ranks are in step again */
  hetinv_optimizer_destroy(&opt);
}

/* Rank 0's progress callback is slow. The other rank, waiting for it in
 * the next iteration's collectives, counted those waits on its clock and
 * passed the budget alone, stopping one iteration before rank 0, which
 * then waited forever; now both stop after the same iteration, by the
 * budget or at the schedule's end, whichever their clocks say. */
static int slow_on_rank_0(const hetinv_progress_t *p, void *user) {
  (void)p;
  if (*(const int *)user == 0) nanosleep(&(struct timespec){0, 20 * 1000 * 1000}, NULL);
  return 0;
}
/* Asks to stop after iteration 3, on rank 0 only. */
static int stop_on_rank_0(const hetinv_progress_t *p, void *user) {
  return *(const int *)user == 0 && p->iteration == 3;
}

static void stops_are_taken_by_every_rank(void **state) {
  scene_t *s = *state;
  hetinv_optimizer_t *opt = optimizer(s, 40);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_TIME_BUDGET, 0.1));
  assert_ok(hetinv_optimizer_set_progress(opt, slow_on_rank_0, &s->rank));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, s->est, &why));
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  unsigned long long mine[2] = {n, (unsigned long long)why}, lo[2], hi[2];
  MPI_Allreduce(mine, lo, 2, MPI_UNSIGNED_LONG_LONG, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(mine, hi, 2, MPI_UNSIGNED_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
  assert_int_equal(lo[0], hi[0]);
  assert_int_equal(lo[1], hi[1]);
  hetinv_optimizer_destroy(&opt);

  opt = optimizer(s, 20);
  assert_ok(hetinv_optimizer_set_progress(opt, stop_on_rank_0, &s->rank));
  assert_ok(hetinv_optimizer_run(opt, s->est, &why));
  assert_int_equal(why, HETINV_STOP_CALLBACK);
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 3);
  hetinv_optimizer_destroy(&opt);
}

int main(int argc, char **argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  int ranks = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (ranks != 2) {
    fprintf(stderr, "test_mpi_failures: run it on 2 ranks (mpirun -np 2), not %d\n", ranks);
    MPI_Finalize();
    return 2;
  }
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(agree_names_the_failing_rank),
      cmocka_unit_test(a_bad_argument_on_one_rank_fails_every_rank),
      cmocka_unit_test(arguments_that_differ_are_refused),
      cmocka_unit_test(out_of_memory_on_one_rank_fails_every_rank),
      cmocka_unit_test(a_checkpoint_rank_0_cannot_write_fails_every_rank),
      cmocka_unit_test(schedules_that_differ_are_refused_before_the_run),
      cmocka_unit_test(stops_are_taken_by_every_rank),
  };
  int failed = cmocka_run_group_tests_name("failures under MPI", tests, setup, teardown);
  int any = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return any != 0;
}
