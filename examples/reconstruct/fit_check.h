/* The data-or-optimizer test by the loss itself: is the recovery a better
 * fit to the data than the truth? */
#ifndef HETINV_RECON_FIT_CHECK_H
#define HETINV_RECON_FIT_CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "recon.h"

/* Misfits Σ mask·w·(I(x) − Ī)² of the data Ī with the noise-free model I at
 * x = the truth and x = the recovery, each estimated without bias from a
 * render (the render's own variance taken out of every term) with its
 * standard error; both renders use the same photons (common random
 * numbers), so their difference is known more precisely than either. */
typedef struct fit_check {
  double truth, truth_se;       /* misfit at the truth */
  double recovery, recovery_se; /* misfit at the recovery */
  double difference_se;         /* of recovery − truth */
  double expected;              /* E[misfit at the truth] from the data's noise: Σ mask·w·σ² */
  size_t values;                /* values in the loss (mask set, weight > 0) */
  double seconds;
  /* The value with the largest share of difference_se² (a heavy-tailed
   * render error shows up here): its row, whether the row is in bins,
   * the data and their standard error, the truth's render and its error. */
  struct {
    double share;
    int32_t row;
    bool bins;
    double data, data_se, render, render_se;
  } worst;
  double top10_share; /* the ten largest shares together */
  /* The truth's render against the data in standard errors,
   * z = √w·(I − Ī): how many values lie beyond FIT_CHECK_TAILS[j], and
   * the share of Σ w·(I − Ī)² those beyond 10 hold. What a robust loss
   * (estimator.loss_clip) would clip at the truth. */
  size_t beyond[3];
  double beyond10_share;
  /* recovery − truth and its error over the values left after the ten
   * with the largest shares of the error's variance: a comparison on a
   * subset chosen by both renders' variance alike (not by which fits
   * better), which one heavy-tailed value cannot swamp. */
  double trimmed_difference, trimmed_se;
  /* The run's own loss (Huber's with the scene's clip, or least squares)
   * at the recovery minus at the truth, from `loss_replicates` pairs of
   * renders on independent streams (within a pair both share photons):
   * the mean over pairs and its standard error from their spread. This is
   * what the optimizer minimised, with each render's own variance taken
   * out of the terms within the clip (as the misfit takes it out of all).
   * What one heavy-tailed value adds is bounded by the clip, so this
   * comparison can decide where the misfit above cannot. */
  double loss_truth, loss_difference, loss_difference_se;
  int32_t loss_replicates;
} fit_check_t;

/* "no difference" (|d| < 2 se), "data" (the recovery fits better) or
 * "optimizer" (the truth fits better) for a difference d ± se. */
const char *fit_check_verdict(double d, double se);

/* Writes <scene->output>/fit_check.csv (replaced whole, never half
 * written): the photons, the misfits and the run's loss comparison with
 * their verdicts. 0, or -1 with errno set. */
int fit_check_store(const recon_scene_t *scene, int64_t photons, const fit_check_t *f);

/* The thresholds of fit_check_t.beyond, in standard errors. */
extern const double FIT_CHECK_TAILS[3];

/* Renders the truth and the recovery at `photons` per emitter against the
 * data `set` (their values, standard errors, weights and mask), once for
 * the misfit and `replicates` (2 or more) times more for the run's loss.
 * Every rank of ctx takes part; the figures are the same on each. */
hetinv_result_t fit_check_compare(hetinv_context_t *ctx, const recon_scene_t *scene, const hetinv_measurements_t *set,
                                  const hetinv_medium_t *truth, const hetinv_medium_t *recovery, int64_t photons,
                                  int32_t replicates, fit_check_t *out);

/* Prints the comparison under the scene's name, with a verdict per figure. */
void fit_check_print(const recon_scene_t *scene, int64_t photons, const fit_check_t *f);

/* Simulates the scene's data (as its cell did), reads the recovery from
 * <scene->output>/recovered_<param>.vol and renders both at `photons` per
 * emitter, once for the misfit and `replicates` (2 or more) times more for
 * the run's loss. 0, or -1 with "<what or file>: <reason>" in msg. */
int fit_check_run(const recon_scene_t *scene, int64_t threads, int64_t photons, int32_t replicates,
                  fit_check_t *out, char *msg, size_t msg_size);

#endif
