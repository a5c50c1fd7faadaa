/* The optimizer's step: one step of every method in every coordinate
 * system against a hand computation (white-box), descent of every method
 * on a tiny problem, the box's projection and margin, frozen entries and
 * masked values. The problem: optimize_problem.h. */
#include <stdlib.h>
#include <string.h>

#include "optimize_problem.h"

/* ------------------------------------------------------------------------ */
/* 1. One step of every method against a hand computation (white-box). */

typedef struct hand {
  hetinv_optimizer_t opt;
  double pi[3], acc1[3], acc2[3], grad[3], scale[3], lo[3], hi[3];
} hand_t;

/* Three entries: σs-like (box [1, 10], scale 9), another (its frozen or
 * bounded twin) and a g-like one (box [-0.99, 0.99], scale 1.98). */
static void hand_init(hand_t *h, int method) {
  memset(h, 0, sizeof *h);
  hetinv_optimizer_t *o = &h->opt;
  o->param[HETINV_OPTIMIZER_METHOD] = method;
  o->param[HETINV_OPTIMIZER_DECAY] = 0.9;
  o->param[HETINV_OPTIMIZER_EPSILON] = 0.01;
  o->param[HETINV_OPTIMIZER_LEARNING_RATE] = 0.1;
  o->param[HETINV_OPTIMIZER_BETA1] = 0.5;
  o->param[HETINV_OPTIMIZER_BETA2] = 0.75;
  o->k = 3;
  o->pi = h->pi, o->acc1 = h->acc1, o->acc2 = h->acc2, o->grad = h->grad;
  o->scale = h->scale, o->lo_k = h->lo, o->hi_k = h->hi;
  o->move_lo_k = h->lo, o->move_hi_k = h->hi; /* no margin */
  const double pi[3] = {5, 5, 0.2}, scale[3] = {9, 9, 1.98}, lo[3] = {1, 1, -0.99}, hi[3] = {10, 10, 0.99};
  memcpy(h->pi, pi, sizeof pi);
  memcpy(h->scale, scale, sizeof scale);
  memcpy(h->lo, lo, sizeof lo);
  memcpy(h->hi, hi, sizeof hi);
}

/* hand_init, stepping in `coordinates`, with one cell's pair: under
 * mean-ratio coordinates entries 0 (σa-like) and 1 (σs-like), else
 * entries 0 (σs) and 2 (g). */
static int64_t hand_pair_second[3] = {2, -1, -1}, hand_pair_first[3] = {-1, -1, 0};
static int64_t mr_pair_second[3] = {1, -1, -1}, mr_pair_first[3] = {-1, 0, -1};
static void hand_init_pair(hand_t *h, int method, int coordinates) {
  hand_init(h, method);
  bool mr = coordinates == HETINV_COORDINATES_LOG_MEAN_RATIO;
  h->opt.param[HETINV_OPTIMIZER_COORDINATES] = coordinates;
  h->opt.pair_second = mr ? mr_pair_second : hand_pair_second;
  h->opt.pair_first = mr ? mr_pair_first : hand_pair_first;
}

static void adadelta_steps_match_hand_computation(void **state) {
  (void)state;
  hand_t h;
  hand_init(&h, HETINV_METHOD_ADADELTA);
  const uint8_t frozen[3] = {0, 1, 0};
  /* Step 1, gradient (2, 7, 0), entry 1 frozen:
   *   E[g²] = 0.1·2² = 0.4;  ε = (0.01·9)² = 0.0081;
   *   δ = sqrt(0 + 0.0081) / sqrt(0.4) · 2 = 0.09·2/sqrt(0.4) = 0.9/sqrt(10);
   *   E[δ²] = 0.1·δ² = 0.0081. Entry 2 (g = 0, E[g²] = 0) does not move. */
  h.grad[0] = 2, h.grad[1] = 7, h.grad[2] = 0;
  double rms = hv_method_step(&h.opt, frozen, 0.01);
  double d1 = 0.9 / sqrt(10.0);
  assert_close(h.acc1[0], 0.4, 1e-15);
  assert_close(h.acc2[0], 0.0081, 1e-15);
  assert_close(h.pi[0], 5 - d1, 1e-14);
  assert_true(h.pi[1] == 5 && h.acc1[1] == 0 && h.acc2[1] == 0); /* frozen: untouched */
  assert_true(h.pi[2] == 0.2 && h.acc1[2] == 0 && h.acc2[2] == 0);
  /* RMS over the two moving entries of δ/s: sqrt(((d1/9)² + 0)/2). */
  assert_close(rms, sqrt((d1 / 9) * (d1 / 9) / 2), 1e-15);
  /* Step 2, gradient (1, 7, -3):
   *   entry 0: E[g²] = 0.9·0.4 + 0.1·1 = 0.46; δ = sqrt(0.0081 + 0.0081)/sqrt(0.46)·1;
   *   entry 2: E[g²] = 0.1·9 = 0.9, ε = (0.0198)²; δ = 0.0198/sqrt(0.9)·(−3), a step up. */
  h.grad[0] = 1, h.grad[2] = -3;
  rms = hv_method_step(&h.opt, frozen, 0.01);
  double d2 = sqrt(0.0162 / 0.46), d2g = 0.0198 / sqrt(0.9) * -3;
  assert_close(h.acc1[0], 0.46, 1e-15);
  assert_close(h.acc2[0], 0.9 * 0.0081 + 0.1 * d2 * d2, 1e-15);
  assert_close(h.pi[0], 5 - d1 - d2, 1e-14);
  assert_close(h.pi[2], 0.2 - d2g, 1e-14);
  assert_true(h.pi[1] == 5);
  assert_close(rms, sqrt(((d2 / 9) * (d2 / 9) + (d2g / 1.98) * (d2g / 1.98)) / 2), 1e-15);
}

/* ADADELTA steps with the ε it is given: with 0.02, ε = (0.02·9)² and
 * δ = sqrt(0.0324) / sqrt(0.4) · 2. A stage's epsilon_start falls
 * linearly to the tunable over the stage's first half. */
static void adadelta_steps_with_the_stage_epsilon(void **state) {
  (void)state;
  hand_t h;
  hand_init(&h, HETINV_METHOD_ADADELTA);
  h.grad[0] = 2;
  hv_method_step(&h.opt, NULL, 0.02);
  assert_close(h.pi[0], 5 - 0.18 * 2 / sqrt(0.4), 1e-14);
  hv_stage_t st = {.iterations = 8, .epsilon_start = 0.05};
  h.opt.stages = &st;
  h.opt.stage = 0;
  const double expect[8] = {0.05, 0.04, 0.03, 0.02, 0.01, 0.01, 0.01, 0.01};
  for (int t = 0; t < 8; ++t) {
    h.opt.stage_iteration = t;
    assert_close(hv_stage_epsilon(&h.opt), expect[t], 1e-15);
  }
  st.epsilon_start = 0.0; /* the tunable throughout */
  h.opt.stage_iteration = 0;
  assert_true(hv_stage_epsilon(&h.opt) == 0.01);
  /* A settling part: the last round(0.3·8) = 2 iterations at 0.002, after
   * epsilon_start's fall. */
  st.epsilon_start = 0.05;
  st.settle_epsilon = 0.002;
  st.settle_fraction = 0.3;
  assert_int_equal(hv_stage_settle_from(&st), 6);
  const double settled[8] = {0.05, 0.04, 0.03, 0.02, 0.01, 0.01, 0.002, 0.002};
  for (int t = 0; t < 8; ++t) {
    h.opt.stage_iteration = t;
    assert_close(hv_stage_epsilon(&h.opt), settled[t], 1e-15);
  }
}

/* SGD, AdaGrad and Adam in scaled coordinates, with projection, at the
 * stage's ε relative to the tunable's. */
static void other_methods_step_as_documented(void **state) {
  (void)state;
  hand_t h;
  /* SGD: δ = rate·s²·g = 0.1·81·2 = 16.2: far below the box, projected to 1. */
  hand_init(&h, HETINV_METHOD_SGD);
  h.grad[0] = 2, h.grad[1] = -0.05, h.grad[2] = 0;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[0] == 1.0);
  assert_close(h.pi[1], 5 + 0.1 * 81 * 0.05, 1e-14);
  assert_true(h.pi[2] == 0.2);
  assert_close(rms, sqrt(((16.2 / 9) * (16.2 / 9) + (0.405 / 9) * (0.405 / 9)) / 3), 1e-14);
  /* AdaGrad: Σg² = 4, δ = 0.1·9·2/2 = 0.9; then Σg² = 4 + 1, δ = 0.1·9·1/sqrt(5). */
  hand_init(&h, HETINV_METHOD_ADAGRAD);
  h.grad[0] = 2;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 4.1, 1e-14);
  assert_true(h.pi[1] == 5 && h.pi[2] == 0.2); /* no gradient yet: no step, no NaN */
  h.grad[0] = 1;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 4.1 - 0.9 / sqrt(5.0), 1e-14);
  /* Adam (β1 = 0.5, β2 = 0.75), t = stage_iteration + 1:
   *   t = 1, g = 2: m = 1, v = 1, m̂ = 2, v̂ = 4, δ = 0.1·9·2/2 = 0.9;
   *   t = 2, g = 1: m = 1, v = 1, m̂ = 1/0.75, v̂ = 1/0.4375, δ = 0.9·(4/3)·sqrt(0.4375). */
  hand_init(&h, HETINV_METHOD_ADAM);
  h.grad[0] = 2;
  h.opt.stage_iteration = 0;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.acc1[0], 1.0, 1e-15);
  assert_close(h.acc2[0], 1.0, 1e-15);
  assert_close(h.pi[0], 4.1, 1e-14);
  h.grad[0] = 1;
  h.opt.stage_iteration = 1;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 4.1 - 0.9 * (4.0 / 3.0) * sqrt(0.4375), 1e-14);
  assert_true(h.pi[1] == 5 && h.pi[2] == 0.2);
  /* A stage's ε schedule scales their step size by its ε over the
   * tunable's (0.01): at 0.0025 SGD moves a quarter as far, Adam's first
   * step 0.9 / 4. */
  hand_init(&h, HETINV_METHOD_SGD);
  h.grad[1] = -0.05;
  hv_method_step(&h.opt, NULL, 0.0025);
  assert_close(h.pi[1], 5 + 0.25 * 0.1 * 81 * 0.05, 1e-14);
  hand_init(&h, HETINV_METHOD_ADAM);
  h.grad[0] = 2;
  h.opt.stage_iteration = 0;
  hv_method_step(&h.opt, NULL, 0.0025);
  assert_close(h.pi[0], 5 - 0.9 / 4, 1e-14);
}

/* Reduced coordinates: σs (entry 0) and g (entry 2) of one cell step as
 * (σs' = σs(1 − g), g) with the chain-ruled gradient; entry 1 stays native. */
static void reduced_coordinates_step_by_the_chain_rule(void **state) {
  (void)state;
  hand_t h;
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_REDUCED);
  h.grad[0] = 0.01, h.grad[1] = 0.001, h.grad[2] = 0.02;
  /* q = 1 − 0.2 = 0.8; ∂L/∂σs' = 0.01/0.8; ∂L/∂g|σs' = 0.02 + 0.01·5/0.8.
   * SGD: δ = rate·s²·gradient with rate 0.1, s = 9 (σs') and 1.98 (g). */
  double dr = 0.1 * 81 * (0.01 / 0.8), dg = 0.1 * 1.98 * 1.98 * (0.02 + 0.01 * 5 / 0.8);
  double g_new = 0.2 - dg, s_new = (5 * 0.8 - dr) / (1 - g_new);
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[2], g_new, 1e-14);
  assert_close(h.pi[0], s_new, 1e-14);
  assert_close(h.pi[1], 5 - 0.1 * 81 * 0.001, 1e-14);
  double d0 = (5 - s_new) / 9, d1 = 0.1 * 81 * 0.001 / 9, d2 = dg / 1.98;
  assert_close(rms, sqrt((d0 * d0 + d1 * d1 + d2 * d2) / 3), 1e-14);
  /* σs(1 − g) moved by exactly the σs' step. */
  assert_close(h.pi[0] * (1 - h.pi[2]), 5 * 0.8 - dr, 1e-14);
  /* The projection: a g step past the box stops at the bound, and σs' is
   * kept inside σs's box. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_REDUCED);
  h.grad[0] = -1, h.grad[2] = -10;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[2] == 0.99 && h.pi[0] == 10);
  /* Native coordinates ignore the pairs. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_NATIVE);
  h.grad[0] = 0.01, h.grad[2] = 0.02;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 5 - 0.1 * 81 * 0.01, 1e-14);
  assert_close(h.pi[2], 0.2 - 0.1 * 1.98 * 1.98 * 0.02, 1e-14);
}

/* Log coordinates: entries 0 and 1 (box [1, 10]) step in ln π with the
 * gradient π·g at scale ln 10; entry 2 (g's box [-0.99, 0.99], not
 * positive) stays native. SGD: δu = rate·s²·(π·g). */
static void log_coordinates_step_by_a_factor(void **state) {
  (void)state;
  hand_t h;
  hand_init(&h, HETINV_METHOD_SGD);
  h.opt.param[HETINV_OPTIMIZER_COORDINATES] = HETINV_COORDINATES_LOG;
  h.pi[1] = 1.5; /* near the floor */
  h.grad[0] = 0.01, h.grad[1] = 0.01, h.grad[2] = 0.02;
  double s = log(10.0);
  double du0 = 0.1 * s * s * (5 * 0.01), du1 = 0.1 * s * s * (1.5 * 0.01);
  double dg = 0.1 * 1.98 * 1.98 * 0.02;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 5 * exp(-du0), 1e-14);
  assert_close(h.pi[1], 1.5 * exp(-du1), 1e-14);
  assert_close(h.pi[2], 0.2 - dg, 1e-14);
  double d0 = du0 / s, d1 = du1 / s, d2 = dg / 1.98;
  assert_close(rms, sqrt((d0 * d0 + d1 * d1 + d2 * d2) / 3), 1e-14);
  /* ADADELTA's first step is sqrt(ε_k / (1 − γ))·sign(g), ε_k = (ε·s)²:
   * the same factor for every value, wherever it sits in the box. */
  hand_init(&h, HETINV_METHOD_ADADELTA);
  h.opt.param[HETINV_OPTIMIZER_COORDINATES] = HETINV_COORDINATES_LOG;
  h.pi[1] = 1.5;
  h.grad[0] = 3.0, h.grad[1] = 3.0;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0] / 5.0, exp(-0.01 * s / sqrt(0.1)), 1e-12);
  assert_close(h.pi[1] / 1.5, exp(-0.01 * s / sqrt(0.1)), 1e-12);
  /* A step past the floor stops at it. */
  hand_init(&h, HETINV_METHOD_SGD);
  h.opt.param[HETINV_OPTIMIZER_COORDINATES] = HETINV_COORDINATES_LOG;
  h.grad[0] = 10.0;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[0] == 1.0);
  /* A box whose ratio hi/lo overflows ([1e-300, 1e50]) still has its
   * finite log width, ln 1e50 − ln 1e-300, and a finite step (it was
   * ln(inf): the step went inf, then NaN). */
  hand_init(&h, HETINV_METHOD_ADADELTA);
  h.opt.param[HETINV_OPTIMIZER_COORDINATES] = HETINV_COORDINATES_LOG;
  h.lo[0] = 1e-300, h.hi[0] = 1e50;
  h.grad[0] = 3.0;
  double wide = log(1e50) - log(1e-300);
  assert_true(isfinite(hv_method_step(&h.opt, NULL, 0.01)));
  assert_close(h.pi[0] / 5.0, exp(-0.01 * wide / sqrt(0.1)), 1e-12);
}

/* Mean-ratio coordinates: entries 0 (σa-like) and 1 (σs-like, both boxes
 * [1, 10]) of one cell step as p = (ln π0 + ln π1)/2, q = (ln π0 − ln π1)/2,
 * entry 2 (g, box [-0.99, 0.99]) natively. SGD at scale s = ln 10:
 * δp = rate·s²·(π0·g0 + π1·g1), δq = rate·s²·(π0·g0 − π1·g1); then
 * π0·exp(−δp − δq), π1·exp(−δp + δq). */
static void mean_ratio_coordinates_step_the_product_and_the_ratio(void **state) {
  (void)state;
  hand_t h;
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_MEAN_RATIO);
  h.pi[1] = 2.0;
  h.grad[0] = 0.01, h.grad[1] = 0.03, h.grad[2] = 0.02;
  double s = log(10.0);
  double ga = 5.0 * 0.01, gb = 2.0 * 0.03;
  double dp = 0.1 * s * s * (ga + gb), dq = 0.1 * s * s * (ga - gb), dg = 0.1 * 1.98 * 1.98 * 0.02;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0], 5.0 * exp(-dp - dq), 1e-14);
  assert_close(h.pi[1], 2.0 * exp(-dp + dq), 1e-14);
  assert_close(h.pi[2], 0.2 - dg, 1e-14);
  double d2 = dg / 1.98;
  assert_close(rms, sqrt(((dp / s) * (dp / s) + (dq / s) * (dq / s) + d2 * d2) / 3), 1e-14);
  /* A gradient that only trades one for the other (π0·g0 = −π1·g1) moves
   * the ratio alone: the product is unchanged. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_MEAN_RATIO);
  h.grad[0] = 0.01, h.grad[1] = -0.01;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0] * h.pi[1], 25.0, 1e-13);
  assert_true(h.pi[0] < 5.0 && h.pi[1] > 5.0);
  /* Frozen σa: σs steps alone in ln π. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_MEAN_RATIO);
  int64_t none[3] = {-1, -1, -1};
  h.opt.pair_second = none;
  h.opt.pair_first = none;
  h.grad[1] = 0.01;
  const uint8_t frozen[3] = {1, 0, 0};
  hv_method_step(&h.opt, frozen, 0.01);
  assert_true(h.pi[0] == 5.0);
  assert_close(h.pi[1], 5.0 * exp(-0.1 * s * s * 0.05), 1e-14);
}

/* Log-reduced coordinates: σs (entry 0) and g (entry 2) of one cell step
 * as (u = ln σs(1 − g), g), entry 1 (box [1, 10]) in ln π. SGD:
 * δu = rate·su²·(σs·∂L/∂σs), su = ln 10; δg = rate·1.98²·(∂L/∂g + ∂L/∂σs·σs/(1 − g)). */
static void log_reduced_coordinates_step_by_the_chain_rule(void **state) {
  (void)state;
  hand_t h;
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_REDUCED);
  h.grad[0] = 0.01, h.grad[1] = 0.001, h.grad[2] = 0.02;
  double su = log(10.0);
  double du = 0.1 * su * su * (5 * 0.01), dg = 0.1 * 1.98 * 1.98 * (0.02 + 0.01 * 5 / 0.8);
  double du1 = 0.1 * su * su * (5 * 0.001);
  double g_new = 0.2 - dg;
  double rms = hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[2], g_new, 1e-14);
  /* σs(1 − g) moved by exactly the factor e^(-δu). */
  assert_close(h.pi[0] * (1 - h.pi[2]), 5 * 0.8 * exp(-du), 1e-14);
  assert_close(h.pi[1], 5 * exp(-du1), 1e-14);
  double d0 = du / su, d1 = du1 / su, d2 = dg / 1.98;
  assert_close(rms, sqrt((d0 * d0 + d1 * d1 + d2 * d2) / 3), 1e-14);
  /* The projection: g stops at its bound, σs at its box's top. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_REDUCED);
  h.grad[0] = -1, h.grad[2] = -10;
  hv_method_step(&h.opt, NULL, 0.01);
  assert_true(h.pi[2] == 0.99 && h.pi[0] == 10);
  /* A σs box that is not positive steps as in reduced coordinates. */
  hand_init_pair(&h, HETINV_METHOD_SGD, HETINV_COORDINATES_LOG_REDUCED);
  h.lo[0] = 0.0;
  h.grad[0] = 0.01, h.grad[2] = 0.02;
  double dr = 0.1 * 81 * (0.01 / 0.8);
  hv_method_step(&h.opt, NULL, 0.01);
  assert_close(h.pi[0] * (1 - h.pi[2]), 5 * 0.8 - dr, 1e-14);
}

/* ------------------------------------------------------------------------ */
/* 2. Every method lowers the loss: σs of a uniform medium from 8 toward 3. */

static void every_method_moves_sigma_s_toward_the_truth(void **state) {
  const problem_t *p = *state;
  static const struct { int method; double rate; } methods[] = {
      {HETINV_METHOD_ADADELTA, 0}, {HETINV_METHOD_SGD, 0}, {HETINV_METHOD_ADAGRAD, 0.1}, {HETINV_METHOD_ADAM, 0.05}};
  for (size_t i = 0; i < sizeof methods / sizeof methods[0]; ++i) {
    setup_t s = coarse_setup(p);
    s.method = methods[i].method;
    s.iterations[0] = 25;
    s.window = 5;
    hetinv_optimizer_t *opt = make_optimizer(p, &s);
    if (methods[i].method == HETINV_METHOD_ADADELTA) {
      assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_EPSILON, 0.05));
    } else if (methods[i].method == HETINV_METHOD_SGD) {
      /* SGD needs a rate for the loss's units: about 1/(s²·|g₀|) of the box per step. */
      double grad = 0.0;
      hetinv_medium_t *start = NULL;
      assert_ok(hetinv_medium_clone(p->initial, &start));
      assert_ok(hetinv_medium_commit(start));
      assert_ok(hetinv_estimator_loss_gradient(p->est, start, p->set, p->coarse, NULL, NULL, &grad, 1));
      hetinv_medium_destroy(&start);
      assert_true(grad > 0); /* too much scattering: the loss falls with σs */
      assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_LEARNING_RATE, 0.5 / (81 * grad)));
    } else {
      assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_LEARNING_RATE, methods[i].rate));
    }
    hetinv_stop_reason_t why = HETINV_STOP_NONE;
    assert_ok(hetinv_optimizer_run(opt, p->est, &why));
    assert_int_equal(why, HETINV_STOP_COMPLETED);
    hetinv_medium_t *m = NULL;
    assert_ok(hetinv_optimizer_result(opt, &m));
    double sigma = mean_sigma_s(m);
    size_t n = 0;
    const double *loss = hetinv_optimizer_losses(opt, &n);
    assert_int_equal(n, 25);
    double first = (loss[0] + loss[1] + loss[2]) / 3, last = (loss[22] + loss[23] + loss[24]) / 3;
    if (!(fabs(sigma - TRUTH_SIGMA_S) < 0.5 * fabs(START_SIGMA_S - TRUTH_SIGMA_S)) || !(last < first)) {
      print_error("method %d: sigma_s %g (start %g, truth %g), loss %g -> %g\n", methods[i].method, sigma,
                  START_SIGMA_S, TRUTH_SIGMA_S, first, last);
      fail();
    }
    /* σa and g were not free: untouched. */
    assert_memory_equal(hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A), hetinv_medium_grid(p->initial, HETINV_PARAM_SIGMA_A),
                        4 * sizeof(double));
    assert_memory_equal(hetinv_medium_grid(m, HETINV_PARAM_G), hetinv_medium_grid(p->initial, HETINV_PARAM_G),
                        4 * sizeof(double));
    hetinv_medium_destroy(&m);
    hetinv_optimizer_destroy(&opt);
  }
}

/* ------------------------------------------------------------------------ */
/* 3. Box projection, frozen entries, masked values. */

/* Runs two stages of `method` in `coordinates` with σs's box [4, 4.5], a
 * huge rate (SGD bounces between the bounds, ADADELTA walks into one) and
 * HETINV_OPTIMIZER_BOX_MARGIN `margin`: every iterate lies in [lo, hi],
 * every average and the result in the box. *at_bound: an iterate sat on a
 * bound of the box; *outside: one lay beyond it. */
static void run_against_the_box(const problem_t *p, int method, int coordinates, double margin, double lo,
                                double hi, bool *at_bound, bool *outside) {
  setup_t s = two_stage_setup(p);
  s.method = method;
  s.iterations[0] = s.iterations[1] = 6;
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 4.0, 4.5));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_LEARNING_RATE, 1e6));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_EPSILON, 1));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_COORDINATES, coordinates));
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_BOX_MARGIN, margin));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 12);
  *at_bound = *outside = false;
  for (int i = 0; i < log->count; ++i) {
    size_t k = log->progress[i].stage == 0 ? 1 : 4;
    for (size_t j = 0; j < k; ++j) {
      double x = log->pi[i][j];
      assert_true(x >= lo * (1 - 1e-15) && x <= hi * (1 + 1e-15));
      assert_true(log->avg[i][j] >= 4.0 && log->avg[i][j] <= 4.5);
      *at_bound |= x == 4.0 || x == 4.5;
      *outside |= x < 4.0 || x > 4.5;
    }
  }
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  for (size_t v = 0; v < 4; ++v) {
    double x = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S)[v];
    assert_true(x >= 4.0 && x <= 4.5);
  }
  hetinv_medium_destroy(&m);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

static void iterates_never_leave_the_box(void **state) {
  for (int method = HETINV_METHOD_ADADELTA; method <= HETINV_METHOD_SGD; ++method) {
    bool at_bound = false, outside = false;
    run_against_the_box(*state, method, HETINV_COORDINATES_NATIVE, 0.0, 4.0, 4.5, &at_bound, &outside);
    assert_true(at_bound); /* the projection was exercised */
  }
}

/* HETINV_OPTIMIZER_BOX_MARGIN: the iterates move in the box widened by
 * the margin (natively by m·width each side, in ln π by the factor
 * (hi/lo)^m) and do leave the box; every average, the stages' hand-on
 * and the result are in the box. */
static void iterates_leave_the_box_by_its_margin(void **state) {
  for (int coordinates = HETINV_COORDINATES_NATIVE; coordinates <= HETINV_COORDINATES_LOG; coordinates += 2) {
    for (int method = HETINV_METHOD_ADADELTA; method <= HETINV_METHOD_SGD; ++method) {
      double lo = 3.75, hi = 4.75; /* natively: 4 - 0.5·0.5, 4.5 + 0.5·0.5 */
      if (coordinates == HETINV_COORDINATES_LOG) {
        lo = 4.0 / sqrt(4.5 / 4.0);
        hi = 4.5 * sqrt(4.5 / 4.0);
      }
      bool at_bound = false, outside = false;
      run_against_the_box(*state, method, coordinates, 0.5, lo, hi, &at_bound, &outside);
      assert_true(outside); /* the margin was used */
    }
  }
}

/* The range each entry moves in, white-box: σs's box [4, 4.5] widened
 * natively by 0.5 of its width and, in ln π, by the factor √(4.5/4); a
 * g box reaching past ±0.99 is never narrowed to ±0.99. */
static void the_margin_widens_each_range_within_physics(void **state) {
  const problem_t *p = *state;
  const struct { int coordinates; double lo, hi; } expect[] = {
      {HETINV_COORDINATES_NATIVE, 3.75, 4.75},
      {HETINV_COORDINATES_LOG, 4.0 / sqrt(4.5 / 4.0), 4.5 * sqrt(4.5 / 4.0)},
  };
  hetinv_param_map_t *g_map = NULL;
  assert_ok(hetinv_param_map_create_identity(p->initial, HETINV_FREE(HETINV_PARAM_G), &g_map));
  for (size_t c = 0; c < 3; ++c) {
    hetinv_optimizer_t *opt = NULL;
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 4.0, 4.5));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_G, -0.999, 0.5));
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_BOX_MARGIN, 0.5));
    if (c < 2) assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_COORDINATES, expect[c].coordinates));
    hetinv_stage_t st = {sizeof st, c < 2 ? p->identity : g_map, 1, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
    assert_ok(hetinv_optimizer_add_stage(opt, &st));
    assert_ok(hv_optimizer_alloc_stage_arrays(opt, 4));
    for (size_t i = 0; i < 4; ++i) {
      if (c < 2) {
        assert_close(opt->move_lo_k[i], expect[c].lo, 1e-14);
        assert_close(opt->move_hi_k[i], expect[c].hi, 1e-14);
      } else { /* g natively: [-0.999 - 0.75, 0.5 + 0.75] cut to [-0.999, 0.99] */
        assert_true(opt->move_lo_k[i] == -0.999 && opt->move_hi_k[i] == 0.99);
      }
      assert_true(opt->lo_k[i] == (c < 2 ? 4.0 : -0.999));
    }
    hetinv_optimizer_destroy(&opt);
  }
  hetinv_param_map_destroy(&g_map);
}

/* Mean-ratio coordinates pair each cell's free σa and σs entries, white-
 * box (pair_cells); a σa box starting at 0 (no logs) pairs nothing. */
static void mean_ratio_pairs_each_cells_sigmas(void **state) {
  const problem_t *p = *state;
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(p->initial, HETINV_FREE_ALL, &map));
  size_t k = hetinv_param_map_size(map);
  for (int floor_zero = 0; floor_zero < 2; ++floor_zero) {
    hetinv_optimizer_t *opt = NULL;
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_A, floor_zero ? 0.0 : 0.01, 1.0));
    assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 1.0, 10.0));
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_COORDINATES, HETINV_COORDINATES_LOG_MEAN_RATIO));
    hetinv_stage_t st = {sizeof st, map, 1, NULL, NULL, 0.0, 0, 0.0, 0.0, 0.0};
    assert_ok(hetinv_optimizer_add_stage(opt, &st));
    assert_ok(hv_optimizer_alloc_stage_arrays(opt, k));
    size_t pairs = 0;
    for (size_t i = 0; i < k; ++i) {
      hetinv_param_t pi = HETINV_PARAM_G, pj = HETINV_PARAM_G;
      size_t ci = 0, cj = 0;
      assert_ok(hetinv_param_map_entry(map, i, &pi, &ci));
      int64_t j = opt->pair_second[i];
      if (j < 0) continue;
      assert_ok(hetinv_param_map_entry(map, (size_t)j, &pj, &cj));
      assert_true(pi == HETINV_PARAM_SIGMA_A && pj == HETINV_PARAM_SIGMA_S && ci == cj);
      assert_true(opt->pair_first[j] == (int64_t)i);
      ++pairs;
    }
    assert_int_equal(pairs, floor_zero ? 0 : k / 3);
    hetinv_optimizer_destroy(&opt);
  }
  hetinv_param_map_destroy(&map);
}

static void frozen_entries_never_move(void **state) {
  const problem_t *p = *state;
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, SIGMA_HI));
  const uint8_t frozen[4] = {1, 0, 0, 1};
  hetinv_stage_t st = {sizeof st, p->identity, 6, frozen, NULL, 0.0, 0, 0.0, 0.0, 0.0};
  assert_ok(hetinv_optimizer_add_stage(opt, &st));
  pi_log_t *log = calloc(1, sizeof *log);
  log->opt = opt;
  assert_ok(hetinv_optimizer_set_progress(opt, log_pi, log));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_int_equal(log->count, 6);
  for (int i = 0; i < log->count; ++i) {
    assert_true(log->pi[i][0] == START_SIGMA_S && log->pi[i][3] == START_SIGMA_S);
    assert_true(log->avg[i][0] == START_SIGMA_S && log->avg[i][3] == START_SIGMA_S);
  }
  assert_true(log->pi[5][1] != START_SIGMA_S && log->pi[5][2] != START_SIGMA_S);
  free(log);
  hetinv_optimizer_destroy(&opt);
}

/* All values left out: the loss is 0, so is the gradient, and π stays. */
static void masked_values_give_no_gradient(void **state) {
  const problem_t *p = *state;
  for (int method = 0; method < HETINV_METHOD_COUNT_; ++method) {
    hetinv_optimizer_t *opt = NULL;
    assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_METHOD, method));
    uint8_t *mask = calloc(p->count, 1);
    hetinv_stage_t st = {sizeof st, p->identity, 3, NULL, mask, 0.0, 0, 0.0, 0.0, 0.0};
    assert_ok(hetinv_optimizer_add_stage(opt, &st));
    free(mask); /* copied */
    assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
    double pi[4], avg[4];
    assert_ok(hetinv_optimizer_get_pi(opt, 0, pi, 4));
    assert_ok(hetinv_optimizer_get_pi(opt, 1, avg, 4));
    for (int j = 0; j < 4; ++j) assert_true(pi[j] == START_SIGMA_S && avg[j] == START_SIGMA_S);
    size_t n = 0;
    const double *loss = hetinv_optimizer_losses(opt, &n);
    assert_int_equal(n, 3);
    for (size_t i = 0; i < n; ++i) assert_true(loss[i] == 0.0);
    hetinv_optimizer_destroy(&opt);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(adadelta_steps_match_hand_computation),
      cmocka_unit_test(adadelta_steps_with_the_stage_epsilon),
      cmocka_unit_test(other_methods_step_as_documented),
      cmocka_unit_test(reduced_coordinates_step_by_the_chain_rule),
      cmocka_unit_test(log_coordinates_step_by_a_factor),
      cmocka_unit_test(log_reduced_coordinates_step_by_the_chain_rule),
      cmocka_unit_test(mean_ratio_coordinates_step_the_product_and_the_ratio),
      cmocka_unit_test(every_method_moves_sigma_s_toward_the_truth),
      cmocka_unit_test(iterates_never_leave_the_box),
      cmocka_unit_test(frozen_entries_never_move),
      cmocka_unit_test(iterates_leave_the_box_by_its_margin),
      cmocka_unit_test(the_margin_widens_each_range_within_physics),
      cmocka_unit_test(mean_ratio_pairs_each_cells_sigmas),
      cmocka_unit_test(masked_values_give_no_gradient),
  };
  return cmocka_run_group_tests(tests, problem_setup, problem_teardown);
}
