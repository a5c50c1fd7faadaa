/* The optimizer's contract: tunables and bounds with their exact errors,
 * a configuration frozen once run, stage and creation errors, NULL
 * arguments. The problem: optimize_problem.h. */
#include <stdlib.h>

#include "optimize_problem.h"

/* ------------------------------------------------------------------------ */
/* 1. Tunables and bounds. */

static void tunables_have_documented_defaults_and_bounds(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  static const struct { hetinv_optimizer_param_t id; double def, lo, hi; } expect[] = {
      {HETINV_OPTIMIZER_METHOD, HETINV_METHOD_ADADELTA, 0, HETINV_METHOD_COUNT_ - 1},
      {HETINV_OPTIMIZER_DECAY, 0.95, 0, 0.999999},
      {HETINV_OPTIMIZER_EPSILON, 0.01, 1e-12, 1},
      {HETINV_OPTIMIZER_LEARNING_RATE, 0.01, 1e-300, 1e12},
      {HETINV_OPTIMIZER_BETA1, 0.9, 0, 0.999999},
      {HETINV_OPTIMIZER_BETA2, 0.999, 0, 0.999999},
      {HETINV_OPTIMIZER_MINIBATCH, 0, 0, 2147483647.0},
      {HETINV_OPTIMIZER_ITERATIONS, 100, 1, 1e15},
      {HETINV_OPTIMIZER_TIME_BUDGET, 0, 0, 1e12},
      {HETINV_OPTIMIZER_PLATEAU_WINDOW, 0, 0, 1e9},
      {HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 0.01, 0, 1},
      {HETINV_OPTIMIZER_AVERAGE_WINDOW, 20, 1, 4096},
      {HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, 10, 1, 1e15},
      {HETINV_OPTIMIZER_COORDINATES, HETINV_COORDINATES_NATIVE, 0, HETINV_COORDINATES_COUNT_ - 1},
      {HETINV_OPTIMIZER_SMOOTHNESS, 0, 0, 1e12},
      {HETINV_OPTIMIZER_MULTISCALE, 0, 0, 100},
      {HETINV_OPTIMIZER_BOX_MARGIN, 0, 0, 1},
  };
  assert_int_equal(sizeof expect / sizeof expect[0], HETINV_OPTIMIZER_PARAM_COUNT_);
  for (size_t i = 0; i < sizeof expect / sizeof expect[0]; ++i) {
    double v = -1, lo = -1, hi = -1;
    assert_ok(hetinv_optimizer_get_param(opt, expect[i].id, &v));
    assert_true(v == expect[i].def);
    assert_ok(hetinv_optimizer_param_bounds(expect[i].id, &lo, &hi));
    assert_true(lo == expect[i].lo && hi == expect[i].hi);
    assert_true(lo <= v && v <= hi);
    /* Both bounds are accepted, and read back. */
    assert_ok(hetinv_optimizer_set_param(opt, expect[i].id, lo));
    assert_ok(hetinv_optimizer_get_param(opt, expect[i].id, &v));
    assert_true(v == lo);
    assert_ok(hetinv_optimizer_set_param(opt, expect[i].id, hi));
    assert_ok(hetinv_optimizer_get_param(opt, expect[i].id, &v));
    assert_true(v == hi);
  }
  assert_ok(hetinv_optimizer_param_bounds(HETINV_OPTIMIZER_DECAY, NULL, NULL));
  double lo = 7;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_param_bounds(-1, &lo, NULL));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_param_bounds(HETINV_OPTIMIZER_PARAM_COUNT_, &lo, NULL));
  assert_message_contains("17");
  assert_true(lo == 7);
  hetinv_optimizer_destroy(&opt);
}

static void tunables_reject_bad_values_naming_them(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  static const struct { hetinv_optimizer_param_t id; double value; const char *name, *shown; } bad[] = {
      {HETINV_OPTIMIZER_METHOD, 4, "HETINV_OPTIMIZER_METHOD", "is 4;"},
      {HETINV_OPTIMIZER_METHOD, -1, "HETINV_OPTIMIZER_METHOD", "is -1;"},
      {HETINV_OPTIMIZER_METHOD, 1.5, "HETINV_OPTIMIZER_METHOD", "is 1.5;"},
      {HETINV_OPTIMIZER_DECAY, 1.0, "HETINV_OPTIMIZER_DECAY", "is 1;"},
      {HETINV_OPTIMIZER_DECAY, -0.1, "HETINV_OPTIMIZER_DECAY", "is -0.1;"},
      {HETINV_OPTIMIZER_DECAY, NaN, "HETINV_OPTIMIZER_DECAY", "is nan;"},
      {HETINV_OPTIMIZER_EPSILON, 0, "HETINV_OPTIMIZER_EPSILON", "is 0;"},
      {HETINV_OPTIMIZER_EPSILON, 1.5, "HETINV_OPTIMIZER_EPSILON", "is 1.5;"},
      {HETINV_OPTIMIZER_LEARNING_RATE, 0, "HETINV_OPTIMIZER_LEARNING_RATE", "is 0;"},
      {HETINV_OPTIMIZER_LEARNING_RATE, Inf, "HETINV_OPTIMIZER_LEARNING_RATE", "is inf;"},
      {HETINV_OPTIMIZER_BETA1, 1, "HETINV_OPTIMIZER_BETA1", "is 1;"},
      {HETINV_OPTIMIZER_BETA2, -Inf, "HETINV_OPTIMIZER_BETA2", "is -inf;"},
      {HETINV_OPTIMIZER_MINIBATCH, 2.5, "HETINV_OPTIMIZER_MINIBATCH", "is 2.5;"},
      {HETINV_OPTIMIZER_MINIBATCH, -1, "HETINV_OPTIMIZER_MINIBATCH", "is -1;"},
      {HETINV_OPTIMIZER_MINIBATCH, 2147483648.0, "HETINV_OPTIMIZER_MINIBATCH", "is 2147483648;"},
      {HETINV_OPTIMIZER_ITERATIONS, 0, "HETINV_OPTIMIZER_ITERATIONS", "is 0;"},
      {HETINV_OPTIMIZER_ITERATIONS, 10.25, "HETINV_OPTIMIZER_ITERATIONS", "is 10.25;"},
      {HETINV_OPTIMIZER_TIME_BUDGET, -1, "HETINV_OPTIMIZER_TIME_BUDGET", "is -1;"},
      {HETINV_OPTIMIZER_PLATEAU_WINDOW, 0.5, "HETINV_OPTIMIZER_PLATEAU_WINDOW", "is 0.5;"},
      {HETINV_OPTIMIZER_PLATEAU_TOLERANCE, 1.01, "HETINV_OPTIMIZER_PLATEAU_TOLERANCE", "is 1.01;"},
      {HETINV_OPTIMIZER_AVERAGE_WINDOW, 0, "HETINV_OPTIMIZER_AVERAGE_WINDOW", "is 0;"},
      {HETINV_OPTIMIZER_AVERAGE_WINDOW, 4097, "HETINV_OPTIMIZER_AVERAGE_WINDOW", "is 4097;"},
      {HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, 0, "HETINV_OPTIMIZER_CHECKPOINT_INTERVAL", "is 0;"},
      {HETINV_OPTIMIZER_SMOOTHNESS, -0.5, "HETINV_OPTIMIZER_SMOOTHNESS", "is -0.5;"},
      {HETINV_OPTIMIZER_SMOOTHNESS, NaN, "HETINV_OPTIMIZER_SMOOTHNESS", "is nan;"},
      {HETINV_OPTIMIZER_MULTISCALE, -0.5, "HETINV_OPTIMIZER_MULTISCALE", "is -0.5;"},
      {HETINV_OPTIMIZER_MULTISCALE, 101, "HETINV_OPTIMIZER_MULTISCALE", "is 101;"},
      {HETINV_OPTIMIZER_MULTISCALE, NaN, "HETINV_OPTIMIZER_MULTISCALE", "is nan;"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    double before = -1, after = -2;
    assert_ok(hetinv_optimizer_get_param(opt, bad[i].id, &before));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_param(opt, bad[i].id, bad[i].value));
    assert_message_contains(bad[i].name);
    assert_message_contains(bad[i].shown);
    assert_int_equal(hetinv_context_last_error_code(NULL), HETINV_ERROR_INVALID_ARGUMENT);
    assert_ok(hetinv_optimizer_get_param(opt, bad[i].id, &after));
    assert_true(before == after);
  }
  /* Integral tunables say so; the range is printed exactly. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, 0.5));
  assert_message_contains("an integer in [0, 2147483647]");
  /* Unknown tunables. */
  double v = 0;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_param(opt, -1, 0));
  assert_message_contains("-1");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PARAM_COUNT_, 0));
  assert_message_contains("17");
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_get_param(opt, 99, &v));
  assert_message_contains("99");
  hetinv_optimizer_destroy(&opt);
}

static void bounds_are_validated(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  static const struct { hetinv_param_t param; double lo, hi; const char *name; } bad[] = {
      {HETINV_PARAM_SIGMA_S, 2, 2, "sigma_s"},       /* lo = hi */
      {HETINV_PARAM_SIGMA_S, 3, 2, "sigma_s"},       /* lo > hi */
      {HETINV_PARAM_SIGMA_A, -0.5, 2, "sigma_a"},    /* negative σ */
      {HETINV_PARAM_SIGMA_A, -Inf, 2, "sigma_a"},
      {HETINV_PARAM_SIGMA_A, Inf, Inf, "sigma_a"},
      {HETINV_PARAM_SIGMA_S, NaN, 2, "sigma_s"},
      {HETINV_PARAM_SIGMA_S, 1, NaN, "sigma_s"},
      {HETINV_PARAM_G, -1, 0.5, "g"},                /* g outside (-1, 1) */
      {HETINV_PARAM_G, -0.5, 1, "g"},
      {HETINV_PARAM_G, -0.5, Inf, "g"},
      {HETINV_PARAM_G, 0.5, 0.2, "g"},
  };
  for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_bounds(opt, bad[i].param, bad[i].lo, bad[i].hi));
    assert_message_contains(bad[i].name);
    assert_message_contains("lo < hi");
  }
  /* A finite box wider than the steps' scale can be squared: the steps
   * overflowed to inf, then NaN, and the run still succeeded. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_A, 0, 1e200));
  assert_message_contains("a finite box at most 1e+100 wide");
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_A, 0, HETINV_OPTIMIZER_MAX_BOX_WIDTH));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_bounds(opt, HETINV_PARAM_COUNT, 0, 1));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_optimizer_set_bounds(opt, -1, 0, 1));
  /* Valid ones, an infinite σ bound included. */
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_A, 0, Inf));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 0, 1e-9));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_G, -0.999, 0.999));
  hetinv_optimizer_destroy(&opt);
}

/* Nothing that shapes the run can change once it has started. */
static void configuration_is_frozen_once_run(void **state) {
  const problem_t *p = *state;
  setup_t s = coarse_setup(p);
  s.iterations[0] = 1;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_DECAY, 0.5));
  assert_message_contains("HETINV_OPTIMIZER_DECAY");
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_ITERATIONS, 3));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 0, 5));
  assert_message_contains("sigma_s");
  hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_add_stage(opt, &st));
  double v = 0;
  assert_ok(hetinv_optimizer_get_param(opt, HETINV_OPTIMIZER_DECAY, &v));
  assert_true(v == 0.95);
  hetinv_optimizer_destroy(&opt);
}

static void stage_and_create_errors(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  /* An empty set cannot be optimized. */
  hetinv_measurements_t *empty = NULL;
  assert_ok(hetinv_measurements_create(p->ctx, &empty));
  static char dummy;
  opt = (hetinv_optimizer_t *)(void *)&dummy;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_create(p->ctx, empty, p->initial, &opt));
  assert_null(opt);
  hetinv_measurements_destroy(&empty);
  /* An initial medium of other indices than the set's: refused here, not
   * at the run's first render. */
  hetinv_medium_t *other_ior = NULL;
  assert_ok(hetinv_medium_clone(p->initial, &other_ior));
  assert_ok(hetinv_medium_set_ior(other_ior, 1.5, 1.0));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_create(p->ctx, p->set, other_ior, &opt));
  assert_message_contains("the set was made for");
  assert_null(opt);
  hetinv_medium_destroy(&other_ior);

  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  hetinv_stage_t st = {sizeof st - 1, p->coarse, 1, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("size");
  st.size = sizeof st;
  st.iterations = -1;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("-1");
  st.iterations = 1;
  st.map = NULL;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  /* A map of another grid. */
  hetinv_medium_t *other = make_medium(p->ctx, (int32_t[]){3, 1, 3}, 1.0);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(other, SS, &map));
  st.map = map;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_add_stage(opt, &st));
  assert_message_contains("grid");
  /* No stage: nothing to run, nothing to read. */
  double pi[4];
  hetinv_stop_reason_t why = 42;
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_NONE);
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_get_pi(opt, 0, pi, 1));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_save(opt, ht_path("never")));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_resume(opt, "/nonexistent"));
  size_t n = 99;
  assert_null(hetinv_optimizer_losses(opt, &n));
  assert_int_equal(n, 0);
  /* The result before any run is the initial medium. */
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  assert_true(hetinv_medium_is_committed(m));
  assert_memory_equal(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S), hetinv_medium_grid(p->initial, HETINV_PARAM_SIGMA_S),
                      4 * sizeof(double));
  hetinv_medium_destroy(&m);
  /* get_pi checks its count. */
  st.map = p->coarse;
  assert_ok(hetinv_optimizer_add_stage(opt, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_get_pi(opt, 0, pi, 4));
  assert_message_contains("4");
  hetinv_optimizer_destroy(&opt);
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&other);
}

/* ------------------------------------------------------------------------ */
/* 2. NULL arguments. */

static void null_arguments_are_refused(void **state) {
  const problem_t *p = *state;
  static char dummy;
  hetinv_optimizer_t *const sentinel = (hetinv_optimizer_t *)(void *)&dummy;
  hetinv_optimizer_t *opt = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(NULL, p->set, p->initial, &opt));
  assert_null(opt);
  opt = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(p->ctx, NULL, p->initial, &opt));
  assert_null(opt);
  opt = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(p->ctx, p->set, NULL, &opt));
  assert_null(opt);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_create(p->ctx, p->set, p->initial, NULL));

  hetinv_optimizer_destroy(NULL);
  opt = NULL;
  hetinv_optimizer_destroy(&opt);
  assert_null(opt);

  setup_t s = coarse_setup(p);
  s.iterations[0] = 1;
  opt = make_optimizer(p, &s);
  double v = 0, pi[1];
  hetinv_stage_t st = {sizeof st, p->coarse, 1, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_param(NULL, HETINV_OPTIMIZER_DECAY, 0.5));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_param(NULL, HETINV_OPTIMIZER_DECAY, &v));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_param(opt, HETINV_OPTIMIZER_DECAY, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_bounds(NULL, HETINV_PARAM_G, 0, 0.5));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_stage(NULL, &st));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_add_stage(opt, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_progress(NULL, NULL, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_set_checkpoint(NULL, "x"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_save(NULL, "x"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_save(opt, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_resume(NULL, "x"));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_resume(opt, NULL));
  hetinv_stop_reason_t why = 42;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_run(NULL, p->est, &why));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_run(opt, NULL, &why));
  assert_int_equal(why, HETINV_STOP_NONE);
  hetinv_medium_t *m = (hetinv_medium_t *)(void *)&dummy;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_result(NULL, &m));
  assert_null(m); /* as every call that returns a handle: NULL on failure, whichever argument failed */
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_result(opt, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_pi(NULL, 0, pi, 1));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_optimizer_get_pi(opt, 0, NULL, 1));
  size_t n = 99;
  assert_null(hetinv_optimizer_losses(NULL, &n));
  assert_int_equal(n, 0);
  assert_null(hetinv_optimizer_losses(NULL, NULL));
  /* NULL clears the callback and the checkpoint path; the run needs neither. */
  assert_ok(hetinv_optimizer_set_checkpoint(opt, "/nonexistent/dir/x.ckpt"));
  assert_ok(hetinv_optimizer_set_checkpoint(opt, NULL));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_set_checkpoint(opt, ""));
  assert_message_contains("the checkpoint path is empty");
  assert_ok(hetinv_optimizer_set_progress(opt, NULL, NULL));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_get_pi(opt, 0, pi, 1));
  hetinv_optimizer_destroy(&opt);
  assert_null(opt);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(tunables_have_documented_defaults_and_bounds),
      cmocka_unit_test(tunables_reject_bad_values_naming_them),
      cmocka_unit_test(bounds_are_validated),
      cmocka_unit_test(configuration_is_frozen_once_run),
      cmocka_unit_test(stage_and_create_errors),
      cmocka_unit_test(null_arguments_are_refused),
  };
  return cmocka_run_group_tests(tests, problem_setup, problem_teardown);
}
