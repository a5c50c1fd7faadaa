/* The optimizer's run: minibatch reproducibility, stopping rules and
 * progress, each stage's ε schedule and averaging window, multi-resolution
 * hand-over, layer-wise stages (Fig. 2(b)). The problem:
 * optimize_problem.h. */
#include <stdlib.h>
#include <string.h>

#include "optimize_problem.h"

/* ------------------------------------------------------------------------ */
/* 1. Minibatches. */

static void run_minibatch(const problem_t *p, outcome_t *o) {
  setup_t s = coarse_setup(p);
  s.minibatch = 2;
  s.iterations[0] = 6;
  reference_run(p, &s, 1, o);
}

static void minibatches_are_reproducible(void **state) {
  (void)state;
  problem_t a, b;
  problem_init(&a, 11, 2, 2, 4, false);
  problem_init(&b, 12, 2, 2, 4, false);
  outcome_t *x = calloc(3, sizeof *x);
  run_minibatch(&a, &x[0]);
  run_minibatch(&a, &x[1]);
  assert_same_outcome(&x[0], &x[1]);
  run_minibatch(&b, &x[2]);
  assert_memory_not_equal(x[0].losses, x[2].losses, 6 * sizeof(double));
  /* The minibatch loss is scaled to the whole set: comparable with a full batch. */
  setup_t s = coarse_setup(&a);
  s.iterations[0] = 1;
  outcome_t *full = calloc(1, sizeof *full);
  reference_run(&a, &s, 1, full);
  assert_true(x[0].losses[0] > 0.2 * full->losses[0] && x[0].losses[0] < 5 * full->losses[0]);
  free(full);
  /* Every minibatch of 2 out of 4 emitters is drawn without replacement, and
   * over many iterations every emitter is drawn. */
  int32_t picked[4], scratch[4], seen[4] = {0};
  for (int64_t it = 0; it < 64; ++it) {
    hv_minibatch_pick(5, it, 4, 2, picked, scratch);
    assert_true(picked[0] >= 0 && picked[0] < picked[1] && picked[1] < 4);
    ++seen[picked[0]], ++seen[picked[1]];
  }
  for (int g = 0; g < 4; ++g) assert_true(seen[g] > 8);
  free(x);
  problem_release(&a);
  problem_release(&b);
}

/* A minibatch keeps its values' clip scales: at a clip of 10⁻³ standard
 * errors every value is clipped, and with every scale 10⁹ none is, so the
 * loss is least squares' again, bit for bit. */
static void minibatches_keep_the_clip_scales(void **state) {
  (void)state;
  problem_t a;
  problem_init(&a, 11, 2, 2, 4, false);
  setup_t s = coarse_setup(&a);
  s.minibatch = 2;
  s.iterations[0] = 2;
  outcome_t *x = calloc(3, sizeof *x);
  reference_run(&a, &s, 1, &x[0]);
  assert_ok(hetinv_estimator_set_param(a.est, HETINV_ESTIMATOR_LOSS_CLIP, 1e-3));
  reference_run(&a, &s, 1, &x[1]);
  assert_true(x[1].losses[0] < 0.5 * x[0].losses[0]);
  double *scales = malloc(a.count * sizeof *scales);
  for (size_t i = 0; i < a.count; ++i) scales[i] = 1e9;
  assert_ok(hetinv_measurements_set_clip_scales(a.set, scales, scales, a.count));
  reference_run(&a, &s, 1, &x[2]);
  assert_same_outcome(&x[0], &x[2]);
  free(scales);
  free(x);
  problem_release(&a);
}

/* ------------------------------------------------------------------------ */
/* 2. Stopping rules and progress. */

static void stages_run_their_counts_with_right_progress(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_ITERATIONS, 4));
  hetinv_stage_t a = {sizeof a, p->coarse, 3, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0}, b = {sizeof b, p->identity, 0, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &a));
  assert_ok(hetinv_optimizer_add_stage(opt, &b));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 7);
  size_t n = 0;
  const double *loss = hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 7);
  double elapsed = 0;
  for (int i = 0; i < 7; ++i) {
    const hetinv_progress_t *q = &log->progress[i];
    assert_int_equal(q->size, sizeof(hetinv_progress_t));
    assert_int_equal(q->stage, i < 3 ? 0 : 1);
    assert_int_equal(q->stage_count, 2);
    assert_int_equal(q->iteration, i + 1);
    assert_int_equal(q->stage_iteration, i < 3 ? i + 1 : i - 2);
    assert_int_equal(q->stage_iterations, i < 3 ? 3 : 4);
    assert_int_equal(q->total_iterations, 7);
    assert_true(q->loss == loss[i] && q->loss > 0);
    assert_true(q->step > 0 && isfinite(q->step));
    assert_true(q->elapsed >= elapsed);
    elapsed = q->elapsed;
  }
  /* The run is over: another run() does nothing more. */
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 7);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

static void iterations_default_is_100(void **state) {
  const problem_t *p = *state;
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(p->ctx, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 8));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2));
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  hetinv_stage_t st = {sizeof st, p->coarse, 0, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &st));
  stopper_t s = {.stop_at = -1};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &s));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(s.calls, 100);
  assert_int_equal(s.last.stage_iterations, 100);
  assert_int_equal(s.last.total_iterations, 100);
  /* The estimator's epoch is restored. */
  double epoch = -1;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_EPOCH, &epoch));
  assert_true(epoch == 0);
  hetinv_optimizer_destroy(&opt);
  hetinv_estimator_destroy(&est);
}

static void a_plateau_ends_a_stage_early(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  /* Tolerance 1: no decrease can beat it, so each stage ends after 2·window. */
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 3));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 1));
  hetinv_stage_t a = {sizeof a, p->coarse, 50, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0}, b = {sizeof b, p->identity, 50, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &a));
  assert_ok(hetinv_optimizer_add_stage(opt, &b));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 12);
  assert_int_equal(log->progress[5].stage, 0);
  assert_int_equal(log->progress[6].stage, 1);
  assert_int_equal(log->progress[6].stage_iteration, 1);
  assert_int_equal(log->progress[11].total_iterations, 100); /* plateau stages count in full */
  free(log);
  hetinv_optimizer_destroy(&opt);

  /* Tolerance 0 and a loss that cannot fall (all values masked, loss 0):
   * 0 >= 0, a plateau after 2·window. */
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 2));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 0));
  uint8_t *mask = calloc(p->count, 1);
  hetinv_stage_t c = {sizeof c, p->coarse, 50, NULL, mask, 0.0, 0, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &c));
  free(mask);
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 4);
  hetinv_optimizer_destroy(&opt);
}

static void a_time_budget_stops_the_run(void **state) {
  const problem_t *p = *state;
  setup_t s = coarse_setup(p);
  s.iterations[0] = 50;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  /* Any iteration takes longer than a nanosecond: one iteration, then stop. */
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_TIME_BUDGET, 1e-9));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_TIME_BUDGET);
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 1);
  /* The budget is spent: a second run stops at once. */
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_TIME_BUDGET);
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 1);
  hetinv_optimizer_destroy(&opt);
}

static void the_callback_stops_and_run_continues(void **state) {
  const problem_t *p = *state;
  setup_t s = two_stage_setup(p);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 4, &o[0]);

  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  stopper_t st = {.stop_at = 3};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_CALLBACK);
  assert_int_equal(st.calls, 3);
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 3);
  /* Stop again exactly at the stage boundary, then run to the end. */
  st.stop_at = 4;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_CALLBACK);
  assert_int_equal(st.last.stage, 0);
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(st.calls, 8);
  assert_int_equal(st.last.iteration, 8);
  /* The interrupted run is the uninterrupted one. */
  capture(opt, 4, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  free(o);
  hetinv_optimizer_destroy(&opt);
}

/* ------------------------------------------------------------------------ */
/* 3. Multi-resolution: stage 2 starts from stage 1's averaged result. */

/* A stage whose epsilon_start is the tunable runs bitwise as one without;
 * a larger one moves the run elsewhere; a caller built against the first
 * hetinv_stage_t passes its smaller size and what follows is not read; a
 * bad value is refused. */
static void a_stage_epsilon_start_changes_only_the_first_half(void **state) {
  const problem_t *p = *state;
  outcome_t *o = calloc(4, sizeof *o);
  setup_t s = coarse_setup(p);
  reference_run(p, &s, 1, &o[0]);
  s.epsilon_start[0] = 0.01; /* the tunable's default */
  reference_run(p, &s, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  s.epsilon_start[0] = 0.05;
  reference_run(p, &s, 1, &o[2]);
  assert_true(memcmp(o[0].pi, o[2].pi, sizeof o[0].pi) != 0);
  /* The first version's size: epsilon_start and average_window (0.05 and 5
   * here) are past it, unread. */
  setup_t t = coarse_setup(p);
  t.stages = 0;
  hetinv_optimizer_t *opt = make_optimizer(p, &t);
  hetinv_stage_t v1 = {HETINV_STAGE_SIZE_V1, p->coarse, 8, NULL, NULL, 0.05, 5, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &v1));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[3]);
  hetinv_optimizer_destroy(&opt);
  assert_same_outcome(&o[0], &o[3]);
  const double bad[3] = {-0.01, 1.5, (double)NAN};
  for (int i = 0; i < 3; ++i) {
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, bad[i], 0, 0.0, 0.0, 0.0};
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
    assert_message_contains("epsilon_start");
    hetinv_optimizer_destroy(&opt);
  }
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, -1, 0.0, 0.0, 0.0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("average_window is -1");
  hetinv_optimizer_destroy(&opt);
  free(o);
}

/* A settling part at the tunable's ε whose length is the window runs
 * bitwise as a stage without one; at a smaller ε it moves the run; with
 * the stage's window 0 its result averages the settling iterates alone; a
 * caller built against the second hetinv_stage_t passes its smaller size
 * and the settling members are not read; bad values are refused. */
static void a_stage_settles_at_its_own_epsilon(void **state) {
  const problem_t *p = *state;
  outcome_t *o = calloc(4, sizeof *o);
  setup_t s = coarse_setup(p);
  reference_run(p, &s, 1, &o[0]);
  s.settle_epsilon[0] = 0.01; /* the tunable's default */
  s.settle_fraction[0] = 3.0 / 8; /* 3 iterates: the ring's window */
  reference_run(p, &s, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  s.settle_epsilon[0] = 0.002;
  reference_run(p, &s, 1, &o[2]);
  assert_true(memcmp(o[0].pi, o[2].pi, sizeof o[0].pi) != 0);
  /* 2 settling iterates under the ring's 3: their mean, not the ring's. */
  s.settle_fraction[0] = 0.25;
  s.settle_epsilon[0] = 0.01;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[3]);
  hetinv_optimizer_destroy(&opt);
  assert_memory_equal(o[0].pi, o[3].pi, sizeof o[0].pi);
  s.stage_window[0] = 2;
  s.settle_epsilon[0] = 0.0;
  s.settle_fraction[0] = 0.0;
  reference_run(p, &s, 1, &o[1]);
  assert_memory_equal(o[1].avg, o[3].avg, sizeof o[1].avg);
  assert_true(memcmp(o[0].avg, o[3].avg, sizeof o[0].avg) != 0);
  /* The second version's size: the settling members are past it, unread. */
  setup_t t = coarse_setup(p);
  t.stages = 0;
  opt = make_optimizer(p, &t);
  hetinv_stage_t v2 = {HETINV_STAGE_SIZE_V2, p->coarse, 8, NULL, NULL, 0.0, 0, -5.0, 7.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &v2));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[1]);
  hetinv_optimizer_destroy(&opt);
  assert_same_outcome(&o[0], &o[1]);
  const struct { double epsilon, fraction; const char *named; } bad[] = {
      {-0.01, 0.5, "settle_epsilon is -0.01"}, {1.5, 0.5, "settle_epsilon is 1.5"},
      {(double)NAN, 0.5, "settle_epsilon is nan"}, {0.001, 0.0, "settle_fraction is 0"},
      {0.001, 1.0, "settle_fraction is 1"}, {0.001, (double)NAN, "settle_fraction is nan"},
      {0.0, 0.5, "settle_fraction is 0.5"}};
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, 0, bad[i].epsilon, bad[i].fraction, 0.0};
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
    assert_message_contains(bad[i].named);
    hetinv_optimizer_destroy(&opt);
  }
  free(o);
}

/* The last photons of the estimator's render (hetinv_render_stats_t). */
static uint64_t last_render_photons(const hetinv_estimator_t *est) {
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  return st.photons;
}

/* A settling part of settle_photons alone: at 1× it runs bitwise as a
 * stage without one; at 2× its renders trace twice the photons, the run
 * moves, and the estimator's own count is left as it was; a caller built
 * against the third hetinv_stage_t passes its smaller size and the member
 * is not read; bad values, and a count past the estimator's range, are
 * refused naming settle_photons. */
static void a_stage_settles_with_more_photons(void **state) {
  const problem_t *p = *state;
  outcome_t *o = calloc(3, sizeof *o);
  setup_t s = coarse_setup(p);
  double photons = 0.0;
  assert_ok(hetinv_estimator_get_param(p->est, HETINV_ESTIMATOR_PHOTONS, &photons));
  reference_run(p, &s, 1, &o[0]);
  uint64_t traced = last_render_photons(p->est);
  assert_true(traced > 0);
  s.settle_photons[0] = 1.0;
  s.settle_fraction[0] = 3.0 / 8; /* 3 iterates: the ring's window */
  reference_run(p, &s, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  s.settle_photons[0] = 2.0;
  reference_run(p, &s, 1, &o[2]);
  assert_true(memcmp(o[0].pi, o[2].pi, sizeof o[0].pi) != 0);
  assert_true(last_render_photons(p->est) == 2 * traced);
  double after = 0.0;
  assert_ok(hetinv_estimator_get_param(p->est, HETINV_ESTIMATOR_PHOTONS, &after));
  assert_true(after == photons);
  /* The third version's size: settle_photons is past it, unread. */
  setup_t t = coarse_setup(p);
  t.stages = 0;
  hetinv_optimizer_t *opt = make_optimizer(p, &t);
  hetinv_stage_t v3 = {HETINV_STAGE_SIZE_V3, p->coarse, 8, NULL, NULL, 0.0, 0, 0.0, 0.0, -3.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &v3));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[1]);
  hetinv_optimizer_destroy(&opt);
  assert_same_outcome(&o[0], &o[1]);
  const struct { double photons, fraction; const char *named; } bad[] = {
      {0.5, 0.5, "settle_photons is 0.5"}, {2e6, 0.5, "settle_photons is 2e+06"},
      {(double)NAN, 0.5, "settle_photons is nan"}, {-1.0, 0.5, "settle_photons is -1"},
      {2.0, 0.0, "settle_fraction is 0"}, {2.0, 1.0, "settle_fraction is 1"}};
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, 0, 0.0, bad[i].fraction, bad[i].photons};
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
    assert_message_contains(bad[i].named);
    hetinv_optimizer_destroy(&opt);
  }
  /* 1e6 × 1e9 photons is past HETINV_ESTIMATOR_PHOTONS's 2^48 − 1: the
   * first settling iteration (the stage's first here) is refused, and the
   * estimator keeps its count. */
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 1e9));
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  hetinv_stage_t huge = {sizeof huge, p->coarse, 8, NULL, NULL, 0.0, 0, 0.0, 0.99, 1e6};
  assert_ok(hetinv_optimizer_add_stage(opt, &huge));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_run(opt, p->est, NULL));
  assert_message_contains("settle_photons 1e+06");
  hetinv_optimizer_destroy(&opt);
  assert_ok(hetinv_estimator_get_param(p->est, HETINV_ESTIMATOR_PHOTONS, &after));
  assert_true(after == 1e9);
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, photons));
  free(o);
}

/* A stage's own window: the next stage starts from the average of its
 * last 2 iterates under a tunable window of 3, and the run's result is the
 * last stage's window (4 here, more than the ring's 3: acts as 3). */
static void a_stage_window_sets_what_it_hands_on(void **state) {
  const problem_t *p = *state;
  setup_t s = two_stage_setup(p);
  s.iterations[0] = 6;
  s.stage_window[0] = 2;
  s.stage_window[1] = 4;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 10);
  assert_close(log->avg[5][0], (log->pi[4][0] + log->pi[5][0]) / 2, 1e-12);
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  for (int j = 0; j < 4; ++j) {
    double expect = (log->pi[7][j] + log->pi[8][j] + log->pi[9][j]) / 3;
    assert_close(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[j], expect, 1e-12);
  }
  hetinv_medium_destroy(&m);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

static void the_next_stage_starts_from_the_average(void **state) {
  const problem_t *p = *state;
  setup_t s = two_stage_setup(p);
  s.iterations[0] = 6;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 10);
  assert_int_equal(log->progress[5].stage, 0);
  assert_int_equal(log->progress[6].stage, 1);
  double avg0 = log->avg[5][0];
  /* The average of the last 3 iterates of stage 1. */
  assert_close(avg0, (log->pi[3][0] + log->pi[4][0] + log->pi[5][0]) / 3, 1e-12);
  assert_true(avg0 != log->pi[5][0]);
  /* One ADADELTA step from it: |δ| = EPSILON·s/sqrt(1 - γ) exactly, for g ≠ 0. */
  double step = 0.01 * (SIGMA_HI - SIGMA_LO) / sqrt(1 - 0.95);
  for (int j = 0; j < 4; ++j) {
    double moved = fabs(log->pi[6][j] - avg0);
    assert_true(moved == 0 || fabs(moved - step) < 1e-9);
  }
  /* The final result is stage 2's average over the 2 x 1 x 2 grid. */
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  for (int j = 0; j < 4; ++j) {
    double expect = (log->pi[7][j] + log->pi[8][j] + log->pi[9][j]) / 3;
    assert_close(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[j], expect, 1e-12);
  }
  hetinv_medium_destroy(&m);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

/* ------------------------------------------------------------------------ */
/* 4. Layer-wise stages (Fig. 2(b)). */

static void layerwise_errors(void **state) {
  const problem_t *steady = *state; /* steady rows only: nothing frontlit and resolved */
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(steady->ctx, steady->set, steady->initial, &opt));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, steady->identity, 0.5, 2, 1));
  assert_message_contains("frontlit");
  hetinv_optimizer_destroy(&opt);

  problem_t p;
  problem_init(&p, 3, 3, 3, 1, true);
  assert_ok(hetinv_optimizer_create(p.ctx, p.set, p.initial, &opt));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.coarse, 1.0 / 3, 3, 1));
  assert_message_contains("one value per voxel");
  const double thickness[] = {0, -1, NaN, Inf, -Inf};
  for (size_t i = 0; i < sizeof thickness / sizeof thickness[0]; ++i) {
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.identity, thickness[i], 3, 1));
    assert_message_contains("layer_thickness");
  }
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.identity, 0.5, 0, 1));
  assert_message_contains("layers");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, p.identity, 0.5, 2, -1));
  assert_message_contains("iterations");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_layerwise_stages(opt, NULL, 0.5, 2, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_layerwise_stages(NULL, p.identity, 0.5, 2, 1));
  /* A map of another grid with the same dimensions. */
  hetinv_medium_t *other = NULL;
  assert_ok(hetinv_medium_create(p.ctx, (double[]){0, 0, 0}, (double[]){2, 2, 2}, p.dims, &other));
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(other, SS, &map));
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&other);
  /* A very thin layer: every voxel lies in a deep layer (no overflow). */
  assert_ok(hetinv_optimizer_add_layerwise_stages(opt, p.identity, 1e-300, 1, 1));
  assert_int_equal(opt->stage_count, 1);
  for (size_t i = 0; i < 9; ++i) assert_true(opt->stages[0].frozen[i]);
  hetinv_optimizer_destroy(&opt);
  problem_release(&p);
}

static void layerwise_stages_free_one_layer_each(void **state) {
  (void)state;
  problem_t p;
  problem_init(&p, 3, 3, 3, 1, true); /* 3 x 1 x 3 voxels, one beam at x = 0.5 */
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p.ctx, p.set, p.initial, &opt));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, SIGMA_HI));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_AVERAGE_WINDOW, 1));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_EPSILON, 0.05));
  /* A first coarse stage, then three layers of 1/3 mm. */
  hetinv_stage_t first = {sizeof first, p.coarse, 2, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &first));
  const double h = 1.0 / 3;
  assert_ok(hetinv_optimizer_add_layerwise_stages(opt, p.identity, h, 3, 4));
  assert_int_equal(opt->stage_count, 4);

  /* White-box: stage 1 + n frees the voxels of z = n and keeps the bins
   * whose window ends before sqrt(d² + (2(n+1)h)²), d the distance from the
   * beam's entry point to the pixel's centre. */
  size_t offset = 0;
  int32_t pixels = 0, bins = 0;
  assert_ok(hetinv_measurements_row_layout(p.set, 0, &offset, &pixels, &bins));
  assert_true(pixels == 3 && bins == BINS && p.count == 48);
  for (int n = 0; n < 3; ++n) {
    const hv_stage_t *st = &opt->stages[1 + n];
    assert_int_equal(st->k, 9);
    assert_int_equal(st->iterations == 0 ? st->requested : st->iterations, 4);
    for (int v = 0; v < 9; ++v) assert_int_equal(st->frozen[v] != 0, v / 3 != n);
    for (int b = 0; b < BINS; ++b) {
      for (int px = 0; px < 3; ++px) {
        double d = (px + 0.5) / 3 - p.beam_x[0], depth2 = 2 * (n + 1) * h;
        bool keep = (b + 1) * BIN_WIDTH <= sqrt(d * d + depth2 * depth2);
        assert_int_equal(st->value_mask[(size_t)b * 3 + (size_t)px] != 0, keep);
      }
    }
  }

  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p.est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  assert_int_equal(log->count, 2 + 3 * 4);
  assert_int_equal(log->progress[0].stage_count, 4);
  /* Stage 0 ends with every voxel at its (coarse) average. */
  double before[9];
  for (int v = 0; v < 9; ++v) before[v] = log->avg[1][0];
  for (int n = 0; n < 3; ++n) {
    bool moved = false;
    for (int i = 0; i < 4; ++i) {
      const int row = 2 + 4 * n + i;
      assert_int_equal(log->progress[row].stage, 1 + n);
      for (int v = 0; v < 9; ++v) {
        if (v / 3 != n) {
          assert_true(log->pi[row][v] == before[v]); /* other layers never move */
        } else {
          moved |= log->pi[row][v] != before[v];
        }
      }
    }
    assert_true(moved); /* the layer's own voxels did */
    memcpy(before, log->pi[2 + 4 * n + 3], sizeof before); /* window 1: the average is the last iterate */
  }
  free(log);
  hetinv_optimizer_destroy(&opt);
  problem_release(&p);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(minibatches_are_reproducible),
      cmocka_unit_test(minibatches_keep_the_clip_scales),
      cmocka_unit_test(stages_run_their_counts_with_right_progress),
      cmocka_unit_test(iterations_default_is_100),
      cmocka_unit_test(a_plateau_ends_a_stage_early),
      cmocka_unit_test(a_time_budget_stops_the_run),
      cmocka_unit_test(the_callback_stops_and_run_continues),
      cmocka_unit_test(the_next_stage_starts_from_the_average),
      cmocka_unit_test(a_stage_epsilon_start_changes_only_the_first_half),
      cmocka_unit_test(a_stage_settles_at_its_own_epsilon),
      cmocka_unit_test(a_stage_settles_with_more_photons),
      cmocka_unit_test(a_stage_window_sets_what_it_hands_on),
      cmocka_unit_test(layerwise_errors),
      cmocka_unit_test(layerwise_stages_free_one_layer_each),
  };
  return cmocka_run_group_tests(tests, problem_setup, problem_teardown);
}
