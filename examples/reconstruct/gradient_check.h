/* The data-or-optimizer test by the gradient: where a recovered voxel
 * misses, does the run's own loss still pull it back, and can the run's
 * Monte Carlo budget see that pull?
 *
 * The bound says what the data determine; the fit check whether the
 * recovery fits them better than the truth. Neither says why an optimizer
 * left a voxel that the data determine well. This renders the run's loss
 * gradient (its photons, clip and gain mode, every entry of the finest
 * grid free, all sources at once) `replicates` times on independent
 * streams, at the recovery and at the truth, and gives per entry the
 * mean, its standard error and one replicate's spread:
 * - at the truth, a mean beyond its error says the run's expected loss
 *   does not have its minimum at the truth at this budget (a biased loss:
 *   a clip that cuts one tail, weights read off the data);
 * - at the recovery, a missed voxel whose gradient points back to the
 *   truth beyond its error was left short by the optimizer; one whose
 *   gradient is within its error sits where the run's loss is flat;
 * - mean ÷ spread is the gradient's signal-to-noise ratio per render of
 *   the whole set: a per-entry step normalised by the gradient's RMS
 *   (ADADELTA, Adam) moves an entry about ε·scale·SNR per iteration, so
 *   a small SNR is an approach that the run's iterations cannot finish.
 * The smoothness prior's gradient is not included (it is deterministic
 * and the run adds it itself).
 *
 * The data's side of the same question: how far apart the data hold the
 * truth and the recovery, dᵀF d for d = recovery − truth and F the Fisher
 * information of the data at the truth (Σ_n mask·w·(J d)_n², the loss's
 * weights taken as the data's 1/σ²), linearised at the truth. Its square
 * root is the separation in the data's standard deviations. An efficient
 * unbiased recovery of k entries lies at dᵀF d ~ χ²_k, k ± √(2k): within
 * that, the data cannot tell the recovery from the truth and no optimizer
 * could do better; far beyond it, the data can and the run did not. Each (J d)_n² is the
 * product of two Jacobian–vector products on independent streams, so the
 * estimate is unbiased; the replicates give its error. */
#ifndef HETINV_RECON_GRADIENT_CHECK_H
#define HETINV_RECON_GRADIENT_CHECK_H

#include <stddef.h>
#include <stdint.h>

#include "recon.h"

/* Per entry (σa, σs, g blocks of the identity map, voxel order) at one
 * medium: the mean gradient over the replicates, its standard error and
 * one replicate's standard deviation. */
typedef struct gradient_stats {
  double *mean, *se, *sd;
} gradient_stats_t;

/* What gradient_check_summarise() counts, per parameter. */
typedef struct gradient_summary {
  /* At the truth: entries whose mean lies beyond 3 standard errors (about
   * 0.3 % of them if the run's expected loss is least at the truth). */
  size_t truth_beyond3[3], entries;
  /* At the recovery, over the voxels whose relative error exceeds the
   * threshold: pulled back to the truth beyond 3 standard errors, within
   * them, pushed away beyond them; and the median |SNR| of the pulled. */
  size_t missed[3], pulled[3], flat[3], pushed[3];
  double pulled_snr_median[3];
  double threshold;
} gradient_summary_t;

typedef struct gradient_check {
  gradient_stats_t truth, recovery;
  gradient_summary_t summary;
  double separation2, separation2_se; /* dᵀF d and its standard error */
  int32_t replicates;
  int64_t photons;
  double seconds;
  double *buffer; /* owns the six arrays */
} gradient_check_t;

/* Renders `replicates` (2 or more) gradients of the run's loss on the
 * data `set` at the truth and at the recovery, and as many pairs of
 * Jacobian–vector products for dᵀF d; summarises them against
 * `threshold` (relative error) and writes <scene->output>/gradient_check.exr
 * (maps) and gradient_check.csv (the summary, replaced whole). On failure msg receives "<what or file>: <reason>". */
hetinv_result_t gradient_check_compare(hetinv_context_t *ctx, const recon_scene_t *scene,
                                       const hetinv_measurements_t *set, const hetinv_medium_t *truth,
                                       const hetinv_medium_t *recovery, int32_t replicates, double threshold,
                                       gradient_check_t *out, char *msg, size_t msg_size);

/* gradient_check_compare() on a finished cell: simulates the scene's data
 * (as its cell did) and reads the recovery from
 * <scene->output>/recovered_<param>.vol. 0, or -1 with "<what or file>:
 * <reason>" in msg. */
int gradient_check_run(const recon_scene_t *scene, int64_t threads, int32_t replicates, double threshold,
                       gradient_check_t *out, char *msg, size_t msg_size);

/* Prints the summary under the scene's name. */
void gradient_check_print(const recon_scene_t *scene, const gradient_check_t *g);

void gradient_check_release(gradient_check_t *g);

#endif
