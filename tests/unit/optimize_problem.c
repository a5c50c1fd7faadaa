/* The optimizer tests' shared problem and runs (optimize_problem.h). */
#include <stdlib.h>

#include "optimize_problem.h"

hetinv_context_t *make_context(uint64_t seed) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  init.seed = seed;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  return ctx;
}

hetinv_medium_t *make_medium(hetinv_context_t *ctx, const int32_t dims[3], double sigma_s) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, dims, &m));
  assert_ok(hetinv_medium_fill(m, TRUTH_SIGMA_A, sigma_s, 0.0));
  assert_ok(hetinv_medium_set_ior(m, 1.3, 1.0));
  return m;
}

void problem_init(problem_t *p, uint64_t seed, int32_t nx, int32_t nz, int emitters, bool bins) {
  *p = (problem_t){.ctx = make_context(seed), .dims = {nx, 1, nz}, .emitters = emitters};
  p->truth = make_medium(p->ctx, p->dims, TRUTH_SIGMA_S);
  if (bins) { /* layered truth: σs grows with depth */
    for (int32_t z = 0; z < nz; ++z) {
      for (int32_t x = 0; x < nx; ++x) {
        assert_ok(hetinv_medium_set_voxel(p->truth, x, 0, z, TRUTH_SIGMA_A, 2.0 + z, 0.0));
      }
    }
  }
  assert_ok(hetinv_medium_commit(p->truth));
  p->initial = make_medium(p->ctx, p->dims, START_SIGMA_S);
  assert_ok(hetinv_medium_commit(p->initial));

  const double *pixel = nx == 3 ? (double[]){1.0 / 3, 1} : (double[]){0.5, 1};
  int32_t width = nx == 3 ? 3 : 2;
  assert_ok(hetinv_sensor_create_orthographic(p->truth, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, pixel, width, 1, &p->reflect));
  assert_ok(hetinv_sensor_create_orthographic(p->truth, HETINV_FACE_Z_MAX, (double[]){0, 0, 1},
                                              (double[]){0, 0}, pixel, width, 1, &p->transmit));
  if (bins) {
    double centres[BINS];
    for (int i = 0; i < BINS; ++i) centres[i] = (i + 0.5) * BIN_WIDTH;
    assert_ok(hetinv_pathlength_create_bins(p->ctx, HETINV_WINDOW_BOX, BINS, centres, BIN_WIDTH,
                                            &p->pathlength));
  } else {
    assert_ok(hetinv_pathlength_create_steady(p->ctx, &p->pathlength));
  }
  assert_ok(hetinv_measurements_create(p->ctx, &p->set));
  for (int e = 0; e < emitters; ++e) {
    p->beam_x[e] = (e + 0.5) / emitters;
    assert_ok(hetinv_emitter_create_ideal(p->truth, (double[]){p->beam_x[e], 0.5, -1},
                                          (double[]){0, 0, 1}, &p->beams[e]));
    assert_ok(hetinv_measurements_add(p->set, p->beams[e], p->reflect, p->pathlength, NULL));
    if (!bins) assert_ok(hetinv_measurements_add(p->set, p->beams[e], p->transmit, p->pathlength, NULL));
  }
  p->count = hetinv_measurements_value_count(p->set);

  /* The measured values: the truth rendered once with more photons (epoch 0). */
  assert_ok(hetinv_estimator_create(p->ctx, &p->est));
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 2000));
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_BATCHES, 2));
  double *values = calloc(p->count, sizeof *values);
  assert_non_null(values);
  assert_ok(hetinv_estimator_render(p->est, p->truth, p->set, values, NULL, NULL, p->count));
  assert_ok(hetinv_measurements_set_values(p->set, values, NULL, p->count));
  free(values);
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 100));

  assert_ok(hetinv_param_map_create_coarse(p->initial, (int32_t[]){1, 1, 1}, SS, &p->coarse));
  assert_ok(hetinv_param_map_create_identity(p->initial, SS, &p->identity));
}

void problem_release(problem_t *p) {
  hetinv_param_map_destroy(&p->coarse);
  hetinv_param_map_destroy(&p->identity);
  hetinv_estimator_destroy(&p->est);
  hetinv_measurements_destroy(&p->set);
  for (int e = 0; e < p->emitters; ++e) hetinv_emitter_destroy(&p->beams[e]);
  hetinv_sensor_destroy(&p->reflect);
  hetinv_sensor_destroy(&p->transmit);
  hetinv_pathlength_destroy(&p->pathlength);
  hetinv_medium_destroy(&p->truth);
  hetinv_medium_destroy(&p->initial);
  hetinv_context_destroy(&p->ctx);
}

/* The default problem of most tests: 2 x 1 x 2 voxels, two beams, steady. */
int problem_setup(void **state) {
  problem_t *p = calloc(1, sizeof *p);
  if (p == NULL) return -1;
  problem_init(p, 7, 2, 2, 2, false);
  *state = p;
  return 0;
}

int problem_teardown(void **state) {
  problem_t *p = *state;
  problem_release(p);
  free(p);
  return 0;
}

/* One coarse stage of 8 iterations, ADADELTA, every emitter, window 3. */
setup_t coarse_setup(const problem_t *p) {
  return (setup_t){.stages = 1, .maps = {p->coarse}, .iterations = {8}, .method = HETINV_METHOD_ADADELTA,
                   .minibatch = 0, .window = 3, .interval = 1};
}

/* Coarse (4 iterations) then per voxel (4 iterations). */
setup_t two_stage_setup(const problem_t *p) {
  return (setup_t){.stages = 2, .maps = {p->coarse, p->identity}, .iterations = {4, 4},
                   .method = HETINV_METHOD_ADADELTA, .minibatch = 0, .window = 3, .interval = 1};
}

hetinv_result_t configure(hetinv_optimizer_t *opt, const setup_t *s) {
  hetinv_result_t r = hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, SIGMA_HI);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_METHOD, s->method);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MINIBATCH, s->minibatch);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_AVERAGE_WINDOW, s->window);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, s->interval);
  for (int i = 0; r == HETINV_SUCCESS && i < s->stages; ++i) {
    hetinv_stage_t st = {sizeof st, s->maps[i], s->iterations[i], NULL, NULL, s->epsilon_start[i],
                         s->stage_window[i], s->settle_epsilon[i], s->settle_fraction[i], s->settle_photons[i]};
    r = hetinv_optimizer_add_stage(opt, &st);
  }
  return r;
}

hetinv_optimizer_t *make_optimizer(const problem_t *p, const setup_t *s) {
  hetinv_optimizer_t *opt = NULL;
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, p->initial, &opt));
  assert_ok(configure(opt, s));
  return opt;
}

void capture(const hetinv_optimizer_t *opt, size_t k, outcome_t *o) {
  memset(o, 0, sizeof *o);
  o->k = k;
  assert_ok(hetinv_optimizer_get_pi(opt, 0, o->pi, k));
  assert_ok(hetinv_optimizer_get_pi(opt, 1, o->avg, k));
  const double *l = hetinv_optimizer_losses(opt, &o->loss_count);
  assert_non_null(l);
  assert_true(o->loss_count <= MAX_LOSSES);
  memcpy(o->losses, l, o->loss_count * sizeof *l);
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_optimizer_result(opt, &m));
  o->voxels = hetinv_medium_voxel_count(m);
  assert_true(o->voxels <= MAX_VOXELS);
  for (int q = 0; q < HETINV_PARAM_COUNT; ++q) memcpy(o->grid[q], hetinv_medium_grid(m, q), o->voxels * sizeof(double));
  hetinv_medium_destroy(&m);
}

void assert_same_outcome(const outcome_t *a, const outcome_t *b) {
  assert_int_equal(a->k, b->k);
  assert_int_equal(a->loss_count, b->loss_count);
  assert_int_equal(a->voxels, b->voxels);
  assert_memory_equal(a->pi, b->pi, sizeof a->pi);
  assert_memory_equal(a->avg, b->avg, sizeof a->avg);
  assert_memory_equal(a->losses, b->losses, sizeof a->losses);
  assert_memory_equal(a->grid, b->grid, sizeof a->grid);
}

/* Runs a configuration to its end from scratch and captures it. */
void reference_run(const problem_t *p, const setup_t *s, size_t k, outcome_t *o) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  capture(opt, k, o);
  hetinv_optimizer_destroy(&opt);
}

/* Mean σs of a medium. */
double mean_sigma_s(const hetinv_medium_t *m) {
  size_t v = hetinv_medium_voxel_count(m);
  const double *g = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S);
  double s = 0.0;
  for (size_t i = 0; i < v; ++i) s += g[i];
  return s / (double)v;
}

/* Records π (last and averaged) and the progress after every iteration. */
int log_pi(const hetinv_progress_t *progress, void *user) {
  pi_log_t *log = user;
  if (log->count >= MAX_LOSSES) return 1;
  size_t k = log->opt->k; /* white-box: the current stage's size */
  if (hetinv_optimizer_get_pi(log->opt, 0, log->pi[log->count], k) != HETINV_SUCCESS) return 1;
  if (hetinv_optimizer_get_pi(log->opt, 1, log->avg[log->count], k) != HETINV_SUCCESS) return 1;
  log->progress[log->count] = *progress;
  ++log->count;
  return 0;
}

int stop_at(const hetinv_progress_t *progress, void *user) {
  stopper_t *s = user;
  ++s->calls;
  s->last = *progress;
  return progress->iteration == s->stop_at;
}
