/* The optimizer schedule of a scene (layer-wise stages, then coarse to
 * fine), a progress line with an ETA, and checkpoint/resume. */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "recon.h"
#include "scene.h"

typedef struct progress_line {
  bool quiet, tty;
  int64_t last_printed;
  double elapsed; /* optimisation seconds so far, across resumes */
  /* Stage results (recon_scene_t.stage_results): the optimizer, the
   * output directory, and the first failure's message (the run stops). */
  const hetinv_optimizer_t *opt;
  hetinv_context_t *ctx;
  const char *stage_dir;
  char failure[2560];
} progress_line_t;

static void format_duration(double s, char *out, size_t n) {
  if (!(s >= 0.0) || s > 1e7) {
    snprintf(out, n, "--");
  } else if (s >= 3600.0) {
    snprintf(out, n, "%dh%02dm", (int)(s / 3600.0), (int)fmod(s / 60.0, 60.0));
  } else {
    snprintf(out, n, "%dm%02ds", (int)(s / 60.0), (int)fmod(s, 60.0));
  }
}

/* Writes the hand-on of a stage that has just done its last iteration (the
 * average the next stage starts from: hetinv_optimizer_result() before
 * the stage ends) as <dir>/stage<n>_<param>.vol, n from 1. A stage that
 * ends early on a plateau is not written. */
static int write_stage_result(progress_line_t *pl, const hetinv_progress_t *p) {
  if (pl->stage_dir == NULL || p->stage + 1 >= p->stage_count || p->stage_iteration != p->stage_iterations ||
      hetinv_context_rank(pl->ctx) != 0) {
    return 0;
  }
  hetinv_medium_t *m = NULL;
  hetinv_result_t r = hetinv_optimizer_result(pl->opt, &m);
  char path[1200] = "";
  for (int q = 0; r == HETINV_SUCCESS && q < 3; ++q) {
    snprintf(path, sizeof path, "%s/stage%d_%s.vol", pl->stage_dir, (int)p->stage + 1, hetinv_param_name(q));
    r = hetinv_medium_write_vol(m, q, path);
  }
  hetinv_medium_destroy(&m);
  if (r == HETINV_SUCCESS) return 0;
  snprintf(pl->failure, sizeof pl->failure, "stage %d's result %.1100s: %.1200s", (int)p->stage + 1, path,
           hetinv_context_last_error_message(pl->ctx));
  return 1;
}

/* A checkpoint at a stage's last iteration is written before the progress
 * callback that writes the stage's result: a run stopped between the two,
 * or whose stage file could not be written (the run then ends with the
 * checkpoint there), resumes past that iteration and would never write
 * the file, yet end as if complete. Resumed exactly there (the checkpoint's
 * iteration count is the stage's end; stage ends are fixed: recon sets no
 * plateau rule), the optimizer's result is still that stage's hand-on, so
 * it is written now. ends[s]: the iterations of stages 0..s. */
static int resumed_stage_result(progress_line_t *pl, const int64_t *ends, const int64_t *lengths, int32_t count) {
  size_t done = 0;
  hetinv_optimizer_losses(pl->opt, &done);
  for (int32_t s = 0; s + 1 < count; ++s) {
    if (ends[s] != (int64_t)done) continue;
    hetinv_progress_t p = {.size = sizeof p, .stage = s, .stage_count = count, .iteration = ends[s],
                           .stage_iteration = lengths[s], .stage_iterations = lengths[s]};
    return write_stage_result(pl, &p);
  }
  return 0;
}

static int on_progress(const hetinv_progress_t *p, void *user) {
  progress_line_t *pl = user;
  pl->elapsed = p->elapsed;
  if (write_stage_result(pl, p) != 0) return 1;
  if (pl->quiet) return 0;
  /* The ETA assumes the remaining iterations cost what the past ones did
   * on average (finer stages cost the same: the photon count is fixed). */
  double eta = p->elapsed / (double)p->iteration * (double)(p->total_iterations - p->iteration);
  char e1[32], e2[32];
  format_duration(p->elapsed, e1, sizeof e1);
  format_duration(eta, e2, sizeof e2);
  bool last = p->iteration == p->total_iterations;
  /* On a terminal the line is redrawn; in a log, one line every 5 %. */
  int64_t every = p->total_iterations / 20 > 0 ? p->total_iterations / 20 : 1;
  if (!pl->tty && !last && p->iteration - pl->last_printed < every) return 0;
  pl->last_printed = p->iteration;
  fprintf(stderr, "%sstage %d/%d  iteration %lld/%lld  loss %.4g  step %.3g  elapsed %s  ETA %s%s",
          pl->tty ? "\r" : "", (int)p->stage + 1, (int)p->stage_count, (long long)p->iteration,
          (long long)p->total_iterations, p->loss, p->step, e1, e2, pl->tty && !last ? "   " : "\n");
  fflush(stderr);
  return 0;
}

hetinv_result_t recon_estimator_configure(hetinv_estimator_t *est, const recon_scene_t *sc) {
  hetinv_result_t r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)sc->photons);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, sc->batches);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_LOSS_CLIP, sc->loss_clip);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_gain_mode(est, sc->gain_mode);
  return r;
}

static hetinv_result_t configure(hetinv_optimizer_t *opt, const recon_scene_t *sc) {
  hetinv_result_t r = HETINV_SUCCESS;
  /* Window 0: average the second half of the finest stage, past its
   * transient (a window longer than the stage would reach back to it), or
   * its settling part (the finest stage's own window, 0, then means that
   * part: hetinv_stage_t.settle_epsilon, settle_photons). */
  int64_t window = sc->average_window > 0 ? sc->average_window : sc->iterations / 2;
  if (sc->average_window == 0 && sc->settle_fraction > 0.0) {
    window = (int64_t)llround(sc->settle_fraction * (double)sc->iterations);
  }
  window = window < 1 ? 1 : (window > 4096 ? 4096 : window);
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) r = hetinv_optimizer_set_bounds(opt, p, sc->bounds_lo[p], sc->bounds_hi[p]);
  struct { hetinv_optimizer_param_t id; double value; } params[] = {
      {HETINV_OPTIMIZER_METHOD, sc->method},
      {HETINV_OPTIMIZER_COORDINATES, sc->coordinates},
      {HETINV_OPTIMIZER_MINIBATCH, sc->minibatch},
      {HETINV_OPTIMIZER_EPSILON, sc->epsilon},
      {HETINV_OPTIMIZER_DECAY, sc->decay},
      {HETINV_OPTIMIZER_LEARNING_RATE, sc->learning_rate},
      {HETINV_OPTIMIZER_BETA1, sc->beta1},
      {HETINV_OPTIMIZER_BETA2, sc->beta2},
      {HETINV_OPTIMIZER_AVERAGE_WINDOW, (double)window},
      {HETINV_OPTIMIZER_TIME_BUDGET, sc->time_budget},
      {HETINV_OPTIMIZER_SMOOTHNESS, sc->smoothness},
      {HETINV_OPTIMIZER_MULTISCALE, sc->multiscale},
      {HETINV_OPTIMIZER_BOX_MARGIN, sc->box_margin},
      {HETINV_OPTIMIZER_ITERATIONS, (double)sc->iterations},
      {HETINV_OPTIMIZER_CHECKPOINT_INTERVAL, 10},
  };
  for (size_t i = 0; r == HETINV_SUCCESS && i < sizeof params / sizeof params[0]; ++i) {
    r = hetinv_optimizer_set_param(opt, params[i].id, params[i].value);
  }
  return r;
}

/* The calibration gain(s) of the recovery: the optimizer's estimator fits
 * them per minibatch, so they are fitted once more on the whole set at the
 * recovered medium, with one loss gradient at GAIN_PHOTON_FACTOR times the
 * run's photons: k = Σ w·I·Ī / Σ w·I² is biased low by the renders'
 * relative variance (Σ I² holds it), measured −41 % at the round trip's
 * 100 photons; ten times the photons cut that bias tenfold for the cost of
 * about ten iterations. */
#define GAIN_PHOTON_FACTOR 10
static hetinv_result_t fit_gains(hetinv_estimator_t *est, int64_t photons,
                                 const hetinv_medium_t *rec, const recon_imaging_t *im,
                                 double **gains, size_t *count) {
  *gains = NULL;
  *count = 0;
  hetinv_param_map_t *map = NULL;
  double *grad = NULL;
  hetinv_result_t r = hetinv_param_map_create_identity(rec, HETINV_FREE_ALL, &map);
  size_t n = r == HETINV_SUCCESS ? hetinv_param_map_size(map) : 0;
  if (r == HETINV_SUCCESS) {
    grad = calloc(n > 0 ? n : 1, sizeof *grad);
    if (grad == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  const double fit_photons = (double)photons * GAIN_PHOTON_FACTOR;
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, fit_photons);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_loss_gradient(est, rec, im->set, map, NULL, NULL, grad, n);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_get_gains(est, NULL, 0, count);
  if (r == HETINV_SUCCESS) {
    *gains = calloc(*count > 0 ? *count : 1, sizeof **gains);
    if (*gains == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  if (r == HETINV_SUCCESS) r = hetinv_estimator_get_gains(est, *gains, *count, count);
  free(grad);
  hetinv_param_map_destroy(&map);
  return r;
}

/* The name of gain i: "all" (global), else the i-th distinct emitter of the
 * rows in order of its first row (HETINV_GAIN_PER_EMITTER's order). */
static const char *gain_name(const recon_imaging_t *im, int mode, size_t i, char *buf, size_t size) {
  if (mode == HETINV_GAIN_GLOBAL) return "all";
  const struct scene *s = im->files;
  if (s != NULL) {
    size_t seen = 0;
    for (int r = 0; r < s->row_count; ++r) {
      int e = s->rows[r].emitter, first = 1;
      for (int q = 0; q < r && first; ++q) first = s->rows[q].emitter != e;
      if (first && seen++ == i) return s->emitters[e].name;
    }
  }
  snprintf(buf, size, "emitter%zu", i);
  return buf;
}

/* Prints the gains and writes <output>/gains.csv atomically. */
static hetinv_result_t write_gains(const recon_scene_t *sc, const recon_imaging_t *im,
                                   const double *gains, size_t count, char *msg, size_t msg_size) {
  char path[1100], tmp[1120], buf[32];
  { /* printed like the run's other results, --quiet or not */
    printf("calibration gain%s (measured per model unit):", count == 1 ? "" : "s");
    for (size_t i = 0; i < count; ++i) {
      printf("%s%s %.6g", i ? ", " : " ", gain_name(im, sc->gain_mode, i, buf, sizeof buf), gains[i]);
    }
    printf("\n");
    fflush(stdout);
  }
  /* 0 is the fit's floor (gain.c): the data hold no light the model
   * renders there, and the recovery was not pulled by them. */
  for (size_t i = 0; i < count; ++i) {
    if (gains[i] == 0.0) {
      fprintf(stderr, "hetinv-reconstruct: calibration gain %s is 0: its measured values hold no light the model "
              "renders (all zero or negative?), so they did not shape the recovery\n",
              gain_name(im, sc->gain_mode, i, buf, sizeof buf));
    }
  }
  snprintf(path, sizeof path, "%s/gains.csv", sc->output);
  FILE *f = text_file_begin(path, tmp, sizeof tmp);
  if (f != NULL) {
    fprintf(f, "emitter,gain\n");
    for (size_t i = 0; i < count; ++i) fprintf(f, "%s,%.9g\n", gain_name(im, sc->gain_mode, i, buf, sizeof buf), gains[i]);
  }
  if (f == NULL || text_file_commit(f, tmp, path) != 0) {
    snprintf(msg, msg_size, "%s: %s", path, strerror(errno));
    return HETINV_ERROR_IO;
  }
  return HETINV_SUCCESS;
}

hetinv_result_t recon_solve(hetinv_context_t *ctx, const recon_scene_t *sc, recon_imaging_t *im,
                            bool resume, bool quiet, hetinv_medium_t **out, double *seconds, char *msg,
                            size_t msg_size) {
  *out = NULL;
  msg[0] = '\0'; /* stays empty where another rank's failure is printed there */
  /* Nothing left to fit is an error, not a "recovery" equal to the start. */
  size_t values = hetinv_measurements_value_count(im->set), masked = 0, weightless = 0;
  const uint8_t *mask = hetinv_measurements_mask(im->set);
  const double *weight = hetinv_measurements_weights(im->set);
  for (size_t i = 0; i < values; ++i) {
    if (mask != NULL && mask[i] == 0) {
      ++masked;
    } else if (weight != NULL && !(weight[i] > 0.0)) {
      ++weightless;
    }
  }
  if (masked + weightless == values) {
    snprintf(msg, msg_size, "no value is left in the loss: %zu of %zu masked (acquisition.min_snr, "
             "acquisition.saturation or the measurements' mask), %zu of weight 0 (acquisition.weighting); "
             "nothing to fit%s", masked, values, weightless,
             masked == values && sc->render_scene[0] == '\0'
                 ? " (if the truth's render is dark, light may not cross the medium at medium.size "
                   "and these coefficients)"
                 : "");
    return HETINV_ERROR_INVALID_ARGUMENT;
  }
  hetinv_medium_t *init = NULL;
  hetinv_optimizer_t *opt = NULL;
  hetinv_estimator_t *est = NULL;
  hetinv_param_map_t *maps[RECON_MAX_LEVELS + 1] = {NULL};
  /* From the truth (optimizer.init "truth"), a recovery that moves away was
   * moved by the data or by the estimator's noise, not by its path from a
   * distant start. */
  hetinv_result_t r = sc->init_at_truth ? recon_truth_create(ctx, sc, &init) : recon_medium_create(ctx, sc, &init);
  if (r == HETINV_SUCCESS && !sc->init_at_truth) r = hetinv_medium_fill(init, sc->init[0], sc->init[1], sc->init[2]);
  if (r == HETINV_SUCCESS) r = hetinv_medium_commit(init);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_create(ctx, im->set, init, &opt);
  if (r == HETINV_SUCCESS) r = configure(opt, sc);
  /* Each stage's iterations and where it ends, for resumed_stage_result. */
  int64_t lengths[HETINV_MAX_STAGES], ends[HETINV_MAX_STAGES];
  int32_t stages = 0;
  if (r == HETINV_SUCCESS && sc->layerwise_layers > 0) {
    r = hetinv_param_map_create_identity(init, HETINV_FREE_ALL, &maps[RECON_MAX_LEVELS]);
    double h = sc->size / sc->grid[0];
    int64_t it = (int64_t)ceil(sc->coarse_fraction * (double)sc->iterations);
    if (r == HETINV_SUCCESS) r = hetinv_optimizer_add_layerwise_stages(opt, maps[RECON_MAX_LEVELS], h, sc->layerwise_layers, (int32_t)it);
    for (int32_t l = 0; r == HETINV_SUCCESS && l < sc->layerwise_layers && stages < HETINV_MAX_STAGES; ++l) {
      lengths[stages++] = it;
    }
  }
  /* Coarse to fine: each level a coarse grid (the last one the voxel grid). */
  for (int32_t l = 0; r == HETINV_SUCCESS && l < sc->level_count; ++l) {
    int32_t cells[3];
    for (int a = 0; a < 3; ++a) cells[a] = sc->grid[a] == 1 ? 1 : (sc->levels[l] < sc->grid[a] ? sc->levels[l] : sc->grid[a]);
    r = hetinv_param_map_create_coarse(init, cells, HETINV_FREE_ALL, &maps[l]);
    bool finest = l + 1 == sc->level_count;
    int64_t it = finest ? sc->iterations : (int64_t)ceil(sc->coarse_fraction * (double)sc->iterations);
    /* A coarse stage hands on the mean of its last coarse_average_window
     * iterates; 0: of the run's window (its whole path if that is longer). */
    hetinv_stage_t stage = {sizeof stage, maps[l], (int32_t)it, NULL, NULL,
                            finest ? sc->epsilon_start : sc->coarse_epsilon_start,
                            finest ? 0 : sc->coarse_average_window,
                            finest ? sc->settle_epsilon : 0.0, finest ? sc->settle_fraction : 0.0,
                            finest ? sc->settle_photons : 0.0};
    if (r == HETINV_SUCCESS) r = hetinv_optimizer_add_stage(opt, &stage);
    if (r == HETINV_SUCCESS && stages < HETINV_MAX_STAGES) lengths[stages++] = it;
  }
  for (int32_t i = 0; i < stages; ++i) ends[i] = (i > 0 ? ends[i - 1] : 0) + lengths[i];
  progress_line_t pl = {.quiet = quiet, .tty = isatty(2) != 0, .opt = opt, .ctx = ctx,
                        .stage_dir = sc->stage_results ? sc->output : NULL};
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_progress(opt, on_progress, &pl);
  char checkpoint[1100];
  snprintf(checkpoint, sizeof checkpoint, "%s/checkpoint.bin", sc->output);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_set_checkpoint(opt, checkpoint);
  struct stat st;
  const bool resuming = resume && stat(checkpoint, &st) == 0;
  if (r == HETINV_SUCCESS && resuming) {
    r = hetinv_optimizer_resume(opt, checkpoint);
    if (r == HETINV_SUCCESS && !quiet) fprintf(stderr, "resuming from %s\n", checkpoint);
    if (r == HETINV_SUCCESS && resumed_stage_result(&pl, ends, lengths, stages) != 0) r = HETINV_ERROR_IO;
  }
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &est);
  if (r == HETINV_SUCCESS) r = recon_estimator_configure(est, sc);
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  /* Under MPI the run and the gains' render are collective: a step that
   * failed on one rank alone (above; rank 0's stage results below) is
   * every rank's failure before them, or the others would wait for it. */
  r = hetinv_context_agree(ctx, r);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_run(opt, est, &why);
  bool stage_failed = pl.failure[0] != '\0'; /* in the run, or on resuming (resumed_stage_result) */
  if (stage_failed) r = HETINV_ERROR_IO;
  r = hetinv_context_agree(ctx, r);
  if (r == HETINV_SUCCESS) r = hetinv_optimizer_result(opt, out);
  if (seconds) *seconds = pl.elapsed;
  if (stage_failed) {
    snprintf(msg, msg_size, "%s", pl.failure);
  } else if (r != HETINV_SUCCESS && !recon_failed_elsewhere(ctx)) {
    snprintf(msg, msg_size, "reconstruction: %s", hetinv_context_last_error_message(ctx));
  }
  double *gains = NULL;
  size_t gain_count = 0;
  if (r == HETINV_SUCCESS && sc->gain_mode != HETINV_GAIN_NONE) {
    r = fit_gains(est, sc->photons, *out, im, &gains, &gain_count);
    if (r != HETINV_SUCCESS) {
      if (!recon_failed_elsewhere(ctx)) snprintf(msg, msg_size, "calibration gain: %s", hetinv_context_last_error_message(ctx));
    } else if (hetinv_context_rank(ctx) == 0) {
      r = write_gains(sc, im, gains, gain_count, msg, msg_size);
    }
  }
  free(gains);
  if (r == HETINV_SUCCESS && hetinv_context_rank(ctx) == 0) {
    /* The loss of every iteration (resumed runs included), written atomically. */
    size_t n = 0;
    const double *losses = hetinv_optimizer_losses(opt, &n);
    char path[1100];
    snprintf(path, sizeof path, "%s/loss.csv", sc->output);
    char tmp[1120];
    FILE *f = text_file_begin(path, tmp, sizeof tmp);
    if (f != NULL) {
      fprintf(f, "iteration,loss\n");
      for (size_t i = 0; i < n; ++i) fprintf(f, "%zu,%.9g\n", i + 1, losses[i]);
    }
    if (f == NULL || text_file_commit(f, tmp, path) != 0) {
      snprintf(msg, msg_size, "%s: %s", path, strerror(errno));
      r = HETINV_ERROR_IO;
    }
  }
  if (r != HETINV_SUCCESS) hetinv_medium_destroy(out);
  for (int i = 0; i <= RECON_MAX_LEVELS; ++i) hetinv_param_map_destroy(&maps[i]);
  hetinv_estimator_destroy(&est);
  hetinv_optimizer_destroy(&opt);
  hetinv_medium_destroy(&init);
  return r;
}
