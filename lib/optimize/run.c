/* The iteration loop: minibatch, loss gradient, step, averaging window,
 * stage changes, stopping rules, progress and checkpoints. */
#include <math.h>
#include <string.h>
#include <time.h>

#include "core/alloc.h"
#include "core/comm.h"
#include "core/error.h"
#include "core/hash.h"
#include "estimator/estimator_internal.h"
#include "optimize/optimizer_internal.h"

/* Keys of the run's agreements under MPI, one per place, so that ranks at
 * different places (or a program's hetinv_context_agree, key 0) are told
 * apart instead of pairing up and hanging at the next collective. */
enum { AGREE_ITERATION = 1, AGREE_NEXT_STAGE = 2, AGREE_CHECKPOINT = 3, AGREE_FINAL_CHECKPOINT = 4 };

static double now_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Room for one more loss, made before an iteration changes anything, so
 * that an iteration either fails with nothing recorded or is recorded whole. */
static hetinv_result_t reserve_loss(hetinv_optimizer_t *opt) {
  if (opt->loss_count < opt->loss_capacity) return HETINV_SUCCESS;
  size_t cap = opt->loss_capacity ? 2 * opt->loss_capacity : 256;
  double *grown = hv_calloc(opt->ctx, cap, sizeof(double));
  if (grown == NULL) return HV_FAIL(opt->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot grow the loss history");
  if (opt->loss_count) memcpy(grown, opt->losses, opt->loss_count * sizeof(double));
  hv_free(opt->ctx, opt->losses);
  opt->losses = grown;
  opt->loss_capacity = cap;
  return HETINV_SUCCESS;
}

/* A stage has ended after its count, or when its last PLATEAU_WINDOW losses
 * are not clearly below the window before. Decided from saved state only,
 * so a resumed run decides the same. */
static bool stage_done(const hetinv_optimizer_t *opt) {
  const hv_stage_t *st = &opt->stages[opt->stage];
  if (opt->stage_iteration >= st->iterations) return true;
  int64_t w = (int64_t)opt->param[HETINV_OPTIMIZER_PLATEAU_WINDOW];
  /* The history holds every iteration (a resumed state is checked so);
   * the guard keeps the window inside it regardless. */
  if (w == 0 || opt->stage_iteration < 2 * w || opt->loss_count < (size_t)(2 * w)) return false;
  const double *l = opt->losses + opt->loss_count - 2 * w;
  double before = 0.0, last = 0.0;
  for (int64_t i = 0; i < w; ++i) {
    before += l[i];
    last += l[w + i];
  }
  return last >= (1.0 - opt->param[HETINV_OPTIMIZER_PLATEAU_TOLERANCE]) * before;
}

/* Ends the current stage: its averaged result becomes the base medium of
 * the next, which starts. Nothing changes until everything the next stage
 * needs is allocated, so that after a failure the optimizer is where it
 * was and the next run ends the stage again. */
static hetinv_result_t next_stage(hetinv_optimizer_t *opt) {
  double *avg = hv_calloc(opt->ctx, opt->k, sizeof(double));
  if (avg == NULL) return HV_FAIL(opt->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu entries", opt->k);
  hv_optimizer_average(opt, avg);
  hetinv_medium_t *base = NULL, *old = opt->base;
  hetinv_result_t r = hetinv_medium_clone(old, &base);
  if (r == HETINV_SUCCESS) r = hetinv_param_map_apply(opt->stages[opt->stage].map, avg, opt->k, base);
  hv_free(opt->ctx, avg);
  if (r == HETINV_SUCCESS) {
    opt->base = base;
    ++opt->stage;
    r = hv_optimizer_begin_stage(opt);
    if (r != HETINV_SUCCESS) {
      --opt->stage;
      opt->base = old;
    }
  }
  if (r != HETINV_SUCCESS) {
    hetinv_medium_destroy(&base);
    return r;
  }
  hetinv_medium_destroy(&old);
  opt->stage_iteration = 0;
  return HETINV_SUCCESS;
}

/* The estimator's photons per emitter for this iteration, or a message
 * naming the stage's settle_photons that asked for a count out of range. */
static hetinv_result_t set_photons(hetinv_optimizer_t *opt, hetinv_estimator_t *est, double photons) {
  hetinv_result_t r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, photons);
  if (r == HETINV_SUCCESS) return r;
  return HV_FAIL(opt->ctx, r, "stage %d: settle_photons %g × the estimator's %.17g photons per emitter = %.17g, out of "
                 "HETINV_ESTIMATOR_PHOTONS's range",
                 (int)opt->stage, opt->stages[opt->stage].settle_photons, opt->est_param[HETINV_ESTIMATOR_PHOTONS],
                 photons);
}

/* One iteration on the current stage. */
static hetinv_result_t iterate(hetinv_optimizer_t *opt, hetinv_estimator_t *est, int32_t *picked,
                               int32_t *scratch, double *loss, double *step) {
  const hv_stage_t *st = &opt->stages[opt->stage];
  int32_t groups = opt->groups.count;
  int32_t size = (int32_t)opt->param[HETINV_OPTIMIZER_MINIBATCH];
  if (size == 0 || size > groups) size = groups;
  hv_minibatch_pick(hetinv_context_seed(opt->ctx), opt->iteration, groups, size, picked, scratch);

  hetinv_measurements_t *sub = NULL;
  hetinv_medium_t *medium = NULL;
  hetinv_result_t r = reserve_loss(opt);
  if (r == HETINV_SUCCESS) r = hv_minibatch_set(opt, picked, size, st->value_mask, &sub);
  if (r == HETINV_SUCCESS) r = hetinv_medium_clone(opt->base, &medium);
  if (r == HETINV_SUCCESS) r = hetinv_param_map_apply(st->map, opt->pi, opt->k, medium);
  if (r == HETINV_SUCCESS) r = hetinv_medium_commit(medium);
  /* Epoch 0 is left to the caller's own renders (e.g. simulated data). */
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, (double)(opt->iteration + 1));
  /* Under MPI a rank that failed above must not leave the others waiting
   * in the loss gradient's collectives. */
  r = hv_comm_agree(opt->ctx, r, AGREE_ITERATION, "the step of the run they are at");
  /* The settling part's photons (hetinv_stage_t.settle_photons), then the
   * estimator's own count back, the one check_estimator recorded. */
  const double photons = opt->est_param[HETINV_ESTIMATOR_PHOTONS];
  const bool more = st->settle_photons != 0.0 && opt->stage_iteration >= hv_stage_settle_from(st);
  if (r == HETINV_SUCCESS && more) r = set_photons(opt, est, fmax(1.0, round(photons * st->settle_photons)));
  if (r == HETINV_SUCCESS) r = hetinv_estimator_loss_gradient(est, medium, sub, st->map, loss, NULL, opt->grad, opt->k);
  if (more) hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, photons);
  hetinv_measurements_destroy(&sub);
  hetinv_medium_destroy(&medium);
  if (r != HETINV_SUCCESS) return r;

  /* Scale the minibatch to the whole set, so that SGD's rate and the
   * reported loss do not depend on the minibatch size. */
  double f = (double)groups / (double)size;
  *loss *= f;
  for (size_t i = 0; i < opt->k; ++i) opt->grad[i] *= f;
  *loss += hv_smoothness_add(opt, st->map, opt->pi, opt->grad);
  hv_multiscale_apply(opt, st->map, st->frozen);
  *step = hv_method_step(opt, st->frozen, hv_stage_epsilon(opt));

  memcpy(opt->ring + (size_t)opt->ring_head * opt->k, opt->pi, opt->k * sizeof(double));
  opt->ring_head = (opt->ring_head + 1) % opt->window;
  if (opt->ring_count < opt->window) ++opt->ring_count;
  return HETINV_SUCCESS;
}

/* Why the ranks stop after an iteration (bits OR-ed over the ranks). */
enum { STOP_CALLBACK = 1u, STOP_BUDGET = 2u };

static int64_t total_iterations(const hetinv_optimizer_t *opt) {
  int64_t n = 0;
  for (int32_t s = 0; s < opt->stage_count; ++s) n += opt->stages[s].iterations;
  return n;
}

/* Starts a fresh run: stage 0 from the initial medium. */
static hetinv_result_t start(hetinv_optimizer_t *opt) {
  hv_optimizer_resolve_iterations(opt);
  hetinv_result_t r = hetinv_medium_clone(opt->initial, &opt->base);
  if (r != HETINV_SUCCESS) return r;
  opt->stage = 0;
  opt->stage_iteration = opt->iteration = 0;
  opt->elapsed = 0.0;
  r = hv_optimizer_begin_stage(opt);
  if (r != HETINV_SUCCESS) {
    hetinv_medium_destroy(&opt->base);
    return r;
  }
  opt->started = true;
  return HETINV_SUCCESS;
}

/* Records the estimator's tunables; a resumed run must use the same. */
static hetinv_result_t check_estimator(hetinv_optimizer_t *opt, const hetinv_estimator_t *est) {
  for (int p = 0; p < HETINV_ESTIMATOR_PARAM_COUNT_; ++p) {
    double v = 0.0;
    hetinv_estimator_get_param(est, p, &v);
    if (p == HETINV_ESTIMATOR_EPOCH) v = 0.0;
    if (opt->verify_est_param && v != opt->est_param[p]) {
      return HV_FAIL(opt->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "the estimator's %s is %.17g; the checkpointed run used %.17g",
                     hv_estimator_param_name(p), v, opt->est_param[p]);
    }
    opt->est_param[p] = v;
  }
  hetinv_gain_mode_t mode = HETINV_GAIN_NONE;
  hetinv_estimator_get_gain_mode(est, &mode);
  if (opt->verify_gain_mode && mode != opt->gain_mode) {
    static const char *const names[] = {"HETINV_GAIN_NONE", "HETINV_GAIN_GLOBAL", "HETINV_GAIN_PER_EMITTER"};
    return HV_FAIL(opt->ctx, HETINV_ERROR_INVALID_ARGUMENT, "the estimator's gain mode is %s; the checkpointed run used %s",
                   names[mode], names[opt->gain_mode]);
  }
  opt->gain_mode = mode;
  opt->have_est_param = true;
  opt->verify_est_param = false;
  opt->verify_gain_mode = false;
  return HETINV_SUCCESS;
}

/* What every rank's run must share before it starts: the tunables, the
 * stages' resolved lengths, where the run stands (a checkpoint resumed on
 * some ranks only) and whether it writes checkpoints (rank 0 writes, all
 * agree on each write). A rank that ran more iterations than another
 * would leave the loop while the others wait in its collectives. */
static uint64_t schedule_key(const hetinv_optimizer_t *opt) {
  uint64_t h = hv_fnv1a_doubles(HV_FNV_OFFSET, opt->param, HETINV_OPTIMIZER_PARAM_COUNT_);
  const int64_t where[5] = {opt->stage_count, opt->stage, opt->stage_iteration, opt->iteration,
                            opt->checkpoint_path != NULL};
  h = hv_fnv1a(h, where, sizeof where);
  for (int32_t s = 0; s < opt->stage_count; ++s) h = hv_fnv1a(h, &opt->stages[s].iterations, sizeof(int64_t));
  return h;
}

HETINV_API hetinv_result_t hetinv_optimizer_run(hetinv_optimizer_t *optimizer,
                                                hetinv_estimator_t *estimator,
                                                hetinv_stop_reason_t *reason) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  hetinv_optimizer_t *opt = optimizer;
  const hetinv_context_t *ctx = opt->ctx;
  if (reason) *reason = HETINV_STOP_NONE;
  /* Under MPI every rank runs this loop in step: a failure on one rank is
   * agreed (hv_comm_agree) before the next collective, and stops by the
   * budget or the callback are taken by all (hv_comm_or). */
  hetinv_result_t r = HETINV_SUCCESS;
  if (estimator == NULL) {
    r = HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'estimator' is NULL");
  } else if (opt->stage_count == 0) {
    r = HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE, "the schedule has no stage: call hetinv_optimizer_add_stage() first");
  }
  if (r == HETINV_SUCCESS && !opt->started) r = start(opt);
  if (r == HETINV_SUCCESS) r = check_estimator(opt, estimator);
  double epoch = 0.0;
  if (r == HETINV_SUCCESS) hetinv_estimator_get_param(estimator, HETINV_ESTIMATOR_EPOCH, &epoch);
  int32_t groups = opt->groups.count;
  int32_t *picked = r == HETINV_SUCCESS ? hv_calloc(ctx, (size_t)groups, sizeof(int32_t)) : NULL;
  int32_t *scratch = r == HETINV_SUCCESS ? hv_calloc(ctx, (size_t)groups, sizeof(int32_t)) : NULL;
  if (r == HETINV_SUCCESS && (picked == NULL || scratch == NULL)) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the minibatch");
  }
  r = hv_comm_agree(ctx, r, r == HETINV_SUCCESS ? schedule_key(opt) : 0,
                    "the optimizer's tunables, stages or progress (iterations done: a checkpoint resumed on some "
                    "ranks only?)");
  if (r != HETINV_SUCCESS) {
    hv_free(ctx, picked);
    hv_free(ctx, scratch);
    return r;
  }

  double budget = opt->param[HETINV_OPTIMIZER_TIME_BUDGET];
  int64_t interval = (int64_t)opt->param[HETINV_OPTIMIZER_CHECKPOINT_INTERVAL];
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  bool over_budget = false;
  while (r == HETINV_SUCCESS && why == HETINV_STOP_NONE) {
    if (stage_done(opt)) {
      if (opt->stage + 1 == opt->stage_count) {
        why = HETINV_STOP_COMPLETED;
        break;
      }
      r = hv_comm_agree(ctx, next_stage(opt), AGREE_NEXT_STAGE, "the step of the run they are at");
      continue;
    }
    /* Past the budget by some rank's clock after the last iteration (the
     * ranks' clocks differ), or, before the first, by the elapsed time a
     * resumed run starts from, the checkpoint's on every rank. Tested after
     * the stage's end, so a run that completes its schedule says so. */
    if (over_budget || (budget > 0.0 && opt->elapsed >= budget)) {
      why = HETINV_STOP_TIME_BUDGET;
      break;
    }
    double t0 = now_seconds(), loss = 0.0, step = 0.0;
    r = iterate(opt, estimator, picked, scratch, &loss, &step);
    if (r != HETINV_SUCCESS) break;
    opt->elapsed += now_seconds() - t0;
    ++opt->stage_iteration;
    ++opt->iteration;
    opt->losses[opt->loss_count++] = loss;
    if (opt->checkpoint_path && opt->iteration % interval == 0) {
      /* Rank 0 writes; every rank learns whether it could. */
      r = hv_comm_agree(ctx, hv_checkpoint_write(opt, opt->checkpoint_path), AGREE_CHECKPOINT,
                        "the step of the run they are at");
    }
    uint32_t stop = budget > 0.0 && opt->elapsed >= budget ? STOP_BUDGET : 0;
    if (r == HETINV_SUCCESS && opt->progress) {
      hetinv_progress_t p = {
          .size = sizeof p,
          .stage = opt->stage,
          .stage_count = opt->stage_count,
          .iteration = opt->iteration,
          .stage_iteration = opt->stage_iteration,
          .stage_iterations = opt->stages[opt->stage].iterations,
          .total_iterations = total_iterations(opt),
          .loss = loss,
          .step = step,
          .elapsed = opt->elapsed,
      };
      const char *entry = hv_api_suspend();
      if (opt->progress(&p, opt->user) != 0) stop |= STOP_CALLBACK;
      hv_api_resume(entry);
    }
    /* A stop one rank asks for (its callback; its clock past the budget,
     * as the ranks' clocks differ) is every rank's. */
    if (r == HETINV_SUCCESS) r = hv_comm_or(ctx, &stop);
    if (stop & STOP_CALLBACK) why = HETINV_STOP_CALLBACK;
    over_budget = (stop & STOP_BUDGET) != 0;
  }
  if (r == HETINV_SUCCESS && opt->checkpoint_path) {
    r = hv_comm_agree(ctx, hv_checkpoint_write(opt, opt->checkpoint_path), AGREE_FINAL_CHECKPOINT,
                      "the step of the run they are at");
  }
  hetinv_estimator_set_param(estimator, HETINV_ESTIMATOR_EPOCH, epoch);
  hv_free(ctx, picked);
  hv_free(ctx, scratch);
  if (reason) *reason = why;
  return r;
}
