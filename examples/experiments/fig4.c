/* hetinv-fig4: the paper's Fig. 4 experiment. Imaging configurations
 * (1) pathlength at the source pixel and its two neighbours, (2) steady
 * state with an orthographic camera on one face and three source
 * orientations, (3) pathlength with several source orientations, (4) (1)
 * with its low-SNR values replaced by (2)'s steady state; several random
 * two-Gaussian volumes; a table of mean and max relative error per
 * parameter and configuration.
 *
 *   hetinv-fig4 [--full] [--volumes N|A-B] [--configs 1,2,3,4] [--iterations N]
 *               [--photons N] [--minibatch N] [--epsilon E] [--epsilon-start E] [--decay D]
 *               [--coarse-epsilon-start E] [--settle-epsilon E] [--settle-fraction F]
 *               [--settle-photons P]
 *               [--coarse-fraction F] [--coarse-levels none|A,B,...] [--stage-results]
 *               [--coarse-window N] [--loss-clip C] [--loss-clip-errors data|residual|residual_above]
 *               [--independent-errors] [--pooled-errors] [--expected-camera-errors] [--residual-weights]
 *               [--smoothness L] [--multiscale A] [--box-margin M] [--truth-photons N] [--seed N]
 *               [--coordinates native|reduced|log|log-reduced|log-mean-ratio] [--grid N] [--scale S]
 *               [--method adadelta|sgd|adagrad|adam] [--rate R] [--beta1 B] [--beta2 B]
 *               [--min-snr S] [--min-snr-errors data|residual] [--threads N] [-o DIR] [--quiet]
 *               [--write-scenes] [--bound | --bound-only] [--bound-photons N]
 *               [--bound-replicates N] [--bound-from DIR] [--init-truth] [--init-geometric] [--fit-check] [--fit-photons N]
 *               [--fit-replicates N]
 *
 * The reduced default (hetinv-reconstruct's built-in scene: a 0.6 mm
 * cube, 6 × 6 section, one 0.1 mm imaging pixel and bin per voxel; 2
 * volumes) ran in 224 s on two cores; --full is the paper's size
 * (10 mm cube, 25 × 25 section, 0.1 mm pixels and bins, 5 volumes, 4000
 * finest iterations, 2000 for configuration (1) and 5000 for (2) and (4),
 * whose last 2000 settle at ε 0.0005; ADADELTA's ε 0.0015). --volumes A-B runs
 * volumes A to B only (side by side in separate folders; copy the cell
 * folders together to tabulate them).
 *
 * --scale S multiplies the σa and σs of the truth's range, the bounds and
 * the start by S: the paper prints [1, 10] mm⁻¹, which makes its 10 mm cube
 * opaque (its centre 10–100 mean free paths from every face); --full reads
 * them as cm⁻¹ (S = 0.1) unless told otherwise.
 *
 * Resumable cell by cell: each finished (configuration, volume) writes
 * DIR/config<c>_volume<v>/cell.csv with its errors, time and a key of
 * every setting it depends on; a rerun with the same settings reads it
 * back instead of recomputing, and an interrupted cell continues from its
 * checkpoint. Delete a cell's folder to recompute it. A finished cell
 * keeps no checkpoint, so a rerun under other settings recomputes it from
 * the start; an interrupted cell's checkpoint, resumed under other data or
 * estimator settings (the loss's clip among them), is refused by the
 * library, naming the difference.
 *
 * --write-scenes writes every selected cell's set-up as files instead
 * (DIR/config<c>_volume<v>/scene/{render.json, truth_*.vol,
 * reconstruct.json}; hetinv-reconstruct --write-scene) for a user to
 * edit, render with hetinv-render and reconstruct from.
 *
 * --bound also computes each cell's Cramér–Rao bound at its truth
 * (hetinv-reconstruct --bound-only: the predicted relative standard
 * deviation of any unbiased recovery from the cell's data; bound.exr and
 * bound_*.png in the cell's folder) and prints it beside the errors, so a
 * miss reads as the data's (error near its bound) or the optimizer's
 * (error far above it); --bound-only computes the bounds alone. Stored in
 * bound.csv and read back like the cells. --bound-photons (default: the
 * scene's photons per emitter) and --bound-replicates (default 4) set its
 * Monte Carlo budget. --bound-from DIR takes a cell's bound from the same
 * cell of another run's folder DIR when it was computed for the same data
 * (its key: the data's settings, the bound's photons and replicates, not
 * the optimizer's), copying it in, so another optimizer setting is set
 * against it at no cost. With --bound a last table (fig4_target.csv) checks
 * the target voxel by voxel: each voxel within 15 %, or within
 * 1.5× its own bound where that bound exceeds 15 % (verdict.c); a voxel
 * that misses both is the optimizer's miss, not the data's. Where a cell's
 * F̂ is not positive definite, the same counts follow against its local
 * bound at each radius (a larger radius sees trades between neighbours;
 * a voxel whose window is not positive definite there is counted apart).
 *
 * --minibatch N sets the sources drawn per iteration (default 16); with
 * --photons it trades sources against photons per source at a fixed
 * number of paths per iteration, which tells the minibatch's sampling
 * noise apart from each source's Monte Carlo noise. --method M steps with
 * M instead of ADADELTA (optimizer.method), --rate R at step size R
 * (optimizer.learning_rate, default 0.01; the ε schedule below scales it
 * as it scales ADADELTA's ε), --beta1 B and --beta2 B with Adam's decays
 * (optimizer.beta1, beta2; default 0.9 and 0.999). --epsilon E sets
 * ADADELTA's ε (default 0.003, 0.0015 with --full), the scale of its
 * steps once the gradient is mostly noise; --epsilon-start E starts the
 * finest stage at that ε, falling linearly to --epsilon's by its middle
 * (optimizer.epsilon_start), --coarse-epsilon-start E each coarser stage
 * (optimizer.coarse_epsilon_start); --settle-epsilon E --settle-fraction F
 * run the finest stage's last fraction F at ε E and average those
 * iterates (optimizer.settle_epsilon, settle_fraction; both or neither;
 * off by default, except (2) and (4) with --full: 0.0005 over 0.4; 0 and
 * 0 turn it off); --settle-photons P renders that settling part (or, in
 * a cell without one, the finest stage's second half) at P times the
 * photons (optimizer.settle_photons; off by default, unlike the
 * built-in scene's 4); --coarse-window N makes each coarse stage hand
 * on the mean of its last N iterates (optimizer.coarse_average_window;
 * default 150 with --full; 0, the reduced default, means the run's window,
 * which at full size is longer than a coarse stage, so it would hand on
 * the mean of its whole path); --loss-clip C makes the loss Huber's, each
 * value's residual counting linearly beyond C of its standard errors
 * (estimator.loss_clip; default with --full 10, and 30 for (1) and (3),
 * 0 = least squares, the reduced default); --loss-clip-errors residual
 * counts C in standard errors of the residual, the data's noise and the
 * optimizer's render's Monte Carlo noise at --photons, instead of the
 * data's, and residual_above does so only where the render is above the
 * data (estimator.loss_clip_errors; default data); --smoothness L adds a
 * smoothness prior of weight L in the loss's units (optimizer.smoothness;
 * default 0, none, and 1500 with --full); --multiscale A
 * adds A times each coarser block's mean gradient to every entry's
 * (optimizer.multiscale; default 1 with --full, 0 reduced); --box-margin M
 * lets the iterates leave each box by M of its width (in ln π under log
 * coordinates) and projects only their average onto it
 * (optimizer.box_margin; default 0, unlike the built-in scene's 0.1); --truth-photons N
 * renders the simulated measurements with N photons per source
 * (acquisition.photons; default 120000 with --full, 30000 reduced): their
 * Monte Carlo error is part of the data's noise; --seed N is the run's
 * seed (the scene's "seed"; default 1): every Monte Carlo draw, the
 * data's render and the optimizer's, changes with it, the truth volume
 * and the camera's noise (seeded per volume) do not, so cells run under
 * several seeds give the spread of a cell's figures;
 * --independent-errors takes the data's Monte Carlo standard errors (and
 * so their weights) from a second render of the truth
 * (acquisition.independent_errors); --pooled-errors takes each value's
 * Monte Carlo variance as its value times the variance-to-value ratio of
 * its neighbours in the image (acquisition.pooled_errors), for the
 * weights, the mask and the bound alike; --expected-camera-errors (a
 * diagnostic) takes each value's camera error from its noise-free value's
 * expected electron count instead of the count recorded, and tests
 * --min-snr on the noise-free value, so that neither a weight nor the mask
 * depends on the camera's draw (acquisition.expected_camera_errors; with
 * --independent-errors neither depends on the data's noise at all);
 * --residual-weights weights each
 * value by 1/variance of the loss's residual, the data's noise plus the
 * optimizer's render's Monte Carlo variance at --photons
 * (acquisition.weighting "residual"), so that Huber's clip counts in
 * standard errors of the residual, not of the data alone;
 * --decay D its running means'
 * decay (default 0.95). --coarse-fraction F gives each coarser level
 * F × the finest level's iterations (optimizer.coarse_fraction; default
 * 0.15). --coarse-levels A,B,... replaces the coarser levels' cells per axis
 * (--full: 3,6,12 before the finest 25; none: the finest level alone),
 * keyed in the cell. --stage-results writes each coarser stage's hand-on, the
 * average the next stage starts from, as stage<n>_<param>.vol in the
 * cell's folder (optimizer.stage_results; not part of the cell's key:
 * it changes no result), so a miss can be traced to the stage that made it. --coordinates reduced moves each voxel's σs and g
 * as (σs(1 − g), g), --coordinates log (the default, the built-in
 * scene's) each value with a positive box in ln π, --coordinates
 * log-reduced both: σs and g as (ln σs(1 − g), g), the rest in ln π,
 * --coordinates log-mean-ratio σa and σs as (ln √(σa·σs), ln √(σa/σs)),
 * the rest in ln π (optimizer.coordinates). --min-snr S leaves out of
 * the loss and the bound every value whose standard error exceeds
 * value/S (acquisition.min_snr of hetinv-reconstruct; default 3, 0 keeps
 * every value); --min-snr-errors residual tests the residual's standard
 * error instead, the data's and the optimizer's render's at --photons
 * (acquisition.min_snr_errors; default data; it recovered worse at full
 * size: the render's noise averages over iterations, the data's does not).
 *
 * --fit-check is the data-or-optimizer test by the loss: for each cell it
 * renders the truth and the stored recovery at --fit-photons per source
 * (default 20000, the same photons for both) and prints the misfit of the
 * data at each (unbiased: the renders' own variance taken out) with its
 * standard error. A recovery that fits the data better than the truth
 * is as far as these data can lead any optimizer; one that fits worse
 * was left short of the data's optimum by the optimizer. The misfit's
 * error is heavy-tailed (rare large contributions to dim values), so it
 * also compares the run's own loss (Huber's clip, --loss-clip) over
 * --fit-replicates pairs of renders (default 4) on independent streams,
 * with an error from their spread. Each cell's check is kept in
 * DIR/config<c>_volume<v>/fit_check.csv.
 *
 * --gradient-check N is the data-or-optimizer test by the gradient
 * (gradient_check.h): for each cell it renders the run's loss gradient N
 * times on independent streams (every source, --photons, the run's clip,
 * every entry of the finest grid free) at the truth and at the stored
 * recovery, and prints per parameter how many voxels off by more than
 * 15 % the loss still pulls back to the truth beyond 3 standard errors
 * (the optimizer stopped short), how many sit where it is flat, and the
 * pulled ones' signal-to-noise ratio per render; at the truth, entries
 * beyond 3 standard errors (the data's own noise puts a few there). It
 * also prints dᵀF d, how far apart the data hold the truth and the
 * recovery (d their difference, F the data's Fisher information at the
 * truth, from paired Jacobian-vector products), against the χ² of the
 * free entries that an efficient unbiased recovery would show. The maps
 * go to DIR/config<c>_volume<v>/gradient_check.exr, the summary to
 * gradient_check.csv beside them.
 *
 * --polish N takes Gauss–Newton steps from each cell's stored recovery
 * (polish.h) and REPLACES it with the result: run it over a copy of a
 * finished run. Each of --polish-steps S (default 2) steps solves
 * (2F̂ + prior Hessian + μ·diag) δ = −g with g the mean of N gradients of
 * the run's loss over every source, F̂ the data's Fisher matrix at the
 * stored recovery (--polish-fisher R replicates, default 2, at
 * --polish-fisher-photons, default the run's --photons), μ from
 * --polish-damping (default 0.01, raised ×4 until the matrix factors)
 * and the step shortened to --polish-max-step (default 0.05) of the box
 * widths, RMS; --polish-cg N solves by at most N conjugate-gradient
 * iterations instead, stopped at the first curvature <= 0. F̂ is kept in
 * polish_fisher.bin beside the cell and reused by a later polish of the
 * same recovery. Per step errors, loss and damping are printed and kept
 * in polish.csv; with --gradient-check the check then measures the
 * polished recovery. Measured in docs/results/fig4.md (fifteenth
 * sitting): not a remedy at the paper's size.
 *
 * --init-truth is a diagnostic: every cell's optimizer starts at its truth
 * and runs the finest level alone (same iterations and photons). A
 * recovery that stays near the truth says the default run's miss comes
 * from its path from the uniform start; one that moves as far away says
 * the data (or the estimator's noise at this budget) do not hold the
 * voxels. Use another -o: the cells' keys differ from the default's.
 *
 * --init-geometric starts σa and σs at the geometric middle of their boxes
 * (sqrt(lo·hi)) instead of the arithmetic one: with log steps, a truth near
 * the box's floor is then as far from the start as one near its top. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cells.h"
#include "fig4_options.h"
#include "fig4_tables.h"
#include "fit_check.h"
#include "gradient_check.h"
#include "polish.h"
#include "interrupted.h"
#include "outdir.h"
#include "runrecord.h"
#include "recon.h"
#include "verdict.h"



/* The scene of configuration c and volume v, with the command line's settings. */
static void make_scene(recon_scene_t *sc, const fig4_options_t *o, int c, int v) {
  const bool full = o->full, init_truth = o->init_truth;
  const int64_t grid = o->grid, iterations = o->iterations, photons = o->photons, minibatch = o->minibatch;
  const double epsilon = o->epsilon, min_snr = o->min_snr, scale = o->scale;
  const char *out = o->out;
  recon_scene_default(sc);
  /* Nor its settling part of 4× the photons: the table was measured
   * without it, and a full-size cell's 15 minutes have no room for twice
   * the run (--settle-epsilon, --settle-fraction set (2) and (4)'s own). */
  sc->settle_photons = 0.0;
  sc->settle_fraction = 0.0;
  /* Not the built-in scene's box margin: at full size it lowered too few
   * figures of unseen volumes, for (2) and for (4), and on the reduced
   * table 17 of 48 (docs/results/fig4.md). */
  sc->box_margin = 0.0;
  snprintf(sc->name, sizeof sc->name, "Fig. 4 %s, volume %d", fig4_config_names[c], v + 1);
  sc->config = (recon_config_t)c;
  sc->truth_seed = (uint64_t)(1000 + v);
  sc->noise_model.seed = (uint64_t)(2000 + v);
  /* The paper: one camera face; sources on every boundary pixel. */
  sc->camera_faces = 1u << HETINV_FACE_Z_MAX;
  sc->angle_count = 3;
  sc->angles[0] = -45.0;
  sc->angles[1] = 0.0;
  sc->angles[2] = 45.0;
  if (full) {
    sc->size = 10.0;
    sc->grid[0] = sc->grid[2] = 25;
    sc->pixels_per_voxel = 4;
    sc->bin_width = 0.1;
    sc->max_pathlength = 20.0;
    sc->level_count = 4;
    int32_t levels[4] = {3, 6, 12, 25};
    memcpy(sc->levels, levels, sizeof levels);
    /* (3)'s optimizer stops short of its data's optimum at 2000: its run's
     * loss at the recovery exceeds the truth's by 12 standard errors on
     * volume 1, by 5 at 4000, and 4000 lowered every figure on volumes 1
     * and 2 (docs/results/fig4.md). Its cells are the table's cheapest,
     * so they can afford it. (2)'s approaches its far σs from above (the
     * start is 4× the truth there) and 2000 iterations left it +16 % on
     * volume 2; 4000 lowered 11 of 12 figures on volumes 1-2, chosen
     * before volumes 3-5 ran (docs/results/fig4.md, with its cost).
     * (4) went to 4000 too (5000 below), since the smoothness prior holds the
     * clusters its data do not split: the longer run removed the σa band
     * volume 3's coarse stages hand on; chosen on volume 6 (4 of 6
     * figures lower), it lowered 22 of volumes 1-5's 30 figures. (1)
     * keeps 2000: its longer runs drifted where its data are weak (tried
     * without the prior). */
    sc->iterations = c == RECON_PATHLENGTH ? 2000 : 4000;
    /* (2) runs 5000, its last 2000 at ε 0.0005, averaged alone (the
     * settling part): started at the truth, that ε stays near (2)'s
     * data's optimum (volume 2: dᵀF d 1.1× an efficient recovery's, 2.8×
     * at 0.0015), but the flat start's approach needs the larger ε.
     * Tried on seed 2's volumes 2–5 (42–70 % of the excess dᵀF d gone on
     * three, the fourth as before), then adopted on seed 1's row
     * (docs/results/fig4.md, seventeenth and eighteenth sittings). (4)
     * likewise: on seed 1's row 22 of 30 figures fell, 6 rose
     * (nineteenth sitting). */
    if (c == RECON_STEADY || c == RECON_COMBINED) {
      sc->iterations = 5000;
      sc->settle_epsilon = 0.0005;
      sc->settle_fraction = 0.4;
    }
    sc->photons = 5000;
    /* Half the reduced scene's ε: at 1875 unknowns the recovery's error
     * follows ADADELTA's step (ε 0.01: 8.2 / 14.5 / 10.9 % mean; 0.003:
     * 4.1 / 4.4 / 4.0 %; 0.0015: 3.8 / 3.1 / 3.3 %; 0.001 converges too
     * slowly for the max), measured on volume 1 (docs/results/fig4.md). */
    sc->epsilon = 0.0015;
    /* Huber's loss at 10 standard errors: a dim camera pixel's rare path,
     * hundreds of times its value, otherwise rules the loss and stalls
     * ADADELTA's steps (volume 2: σs 17.7 → 6.5 % mean, 94.5 → 28.6 %
     * max); and coarse stages that hand on the mean of their second half,
     * not of their whole path (docs/results/fig4.md, volumes 1–5). */
    sc->loss_clip = 10.0;
    /* (1) and (3): 30. The optimizer's render has 24 times fewer photons
     * than the data's, so its noise is about 3.4 of the data's standard
     * errors (volume 1, mean over the values fitted), and a clip at 10 cuts
     * its bright tail often and its dark tail never: the clipped residual
     * comes out too dark, so the gradient brightens dim values. (2) and
     * (4) get the same pull, but their data hold every voxel to 1-5 %,
     * and there a clip at 30 was a wash; (1) and (3) hold their voxels to
     * 12-100 %, so the same pull moved them far (σa low, σs and g high on
     * every volume). On volumes 1-2, chosen before volumes 3-5 ran, 30
     * lowered 10 of 12 figures of each, and σa's mean signed error on
     * volume 1 went from -6 % to -0.3 % (docs/results/fig4.md). */
    if (c == RECON_PATHLENGTH || c == RECON_PATHLENGTH_ANGLES) sc->loss_clip = 30.0;
    sc->coarse_average_window = 150;
    /* The multi-scale step: a smooth error (volume 2: σs 6 % high
     * everywhere) moves with its blocks' mean gradient, not each voxel's
     * noisy one ((4) volume 2: σs 6.5 → 3.5 % mean). And data rendered at
     * 120 000 photons per source: at 30 000 their own Monte Carlo error put
     * a cluster of σa 40 % high on volume 1 ((4): 40.4 → 16.3 % max).
     * Both measured in docs/results/fig4.md. */
    sc->multiscale = 1.0;
    sc->truth_photons = 120000;
    /* Every configuration: a smoothness prior of weight 1500, for the
     * voxels the data leave undetermined (clusters where σa, σs and g
     * trade). Chosen for (4) on volume 6, outside the table, among 0,
     * 1500, 15 000 and 50 000 (1500 lowered 5 of its 6 figures); on
     * volumes 1-5 22 of (4)'s 30 figures fell, 4 rose. The same weight
     * on (1): 26 of 30 lower; on (2) and (3), checked on volume 6 first
     * (5 and 6 of 6 lower), then most of their figures on volumes 1-5
     * (docs/results/fig4.md). */
    sc->smoothness = 1500.0;
  } else {
    /* hetinv-reconstruct's built-in scene: a 0.6 mm cube, 6 × 6 section
     * (0.1 mm voxels, pixels and bins), 1 → 2 → 3 → 6 cells, 600
     * iterations of 16 sources × 2000 photons at the finest level. */
    sc->bin_width = sc->size / sc->grid[0];
    sc->max_pathlength = 4.0 * sc->size;
  }
  if (grid > 0) {
    sc->grid[0] = sc->grid[2] = (int32_t)grid;
    sc->bin_width = sc->size / (double)grid;
    sc->levels[sc->level_count - 1] = (int32_t)grid;
    for (int l = 0; l + 1 < sc->level_count; ++l) {
      if (sc->levels[l] > grid) sc->levels[l] = (int32_t)grid;
    }
  }
  if (iterations > 0) sc->iterations = iterations;
  if (photons > 0) sc->photons = photons;
  if (minibatch > 0) sc->minibatch = (int32_t)minibatch;
  if (epsilon > 0.0) sc->epsilon = epsilon;
  if (min_snr >= 0.0) sc->min_snr = min_snr;
  for (int p = 0; p < 2; ++p) { /* σa and σs; g has no unit */
    sc->truth_lo[p] *= scale;
    sc->truth_hi[p] *= scale;
    sc->bounds_lo[p] *= scale;
    sc->bounds_hi[p] *= scale;
    sc->init[p] *= scale;
  }
  if (o->init_geometric) {
    /* σa and σs start at the geometric middle of their boxes, the middle
     * of the log steps: a far truth near the box's floor is then as many
     * factors away as one near its top. */
    for (int p = 0; p < 2; ++p) sc->init[p] = sqrt(sc->bounds_lo[p] * sc->bounds_hi[p]);
    sc->init_keyed = true;
  }
  if (init_truth) { /* the diagnostic: the finest level alone, from the truth */
    sc->init_at_truth = true;
    sc->levels[0] = sc->levels[sc->level_count - 1];
    sc->level_count = 1;
  }
  (void)recon_scene_set_output(sc, "%s/config%d_volume%d", out, c, v + 1); /* fits: FIG4_CELL_FOLDER_MAX */
  fig4_options_apply(o, sc);
}

/* Writes one cell's set-up as a render scene, its truth and the
 * reconstruction from the rendered files, in <cell>/scene. */
static int write_cell_scene(recon_scene_t *sc) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc->seed;
  hetinv_context_t *ctx = NULL;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return recon_fail("hetinv-fig4", NULL, "context");
  char dir[1100], msg[2048] = "";
  snprintf(dir, sizeof dir, "%s/scene", sc->output);
  hetinv_medium_t *truth = NULL;
  recon_imaging_t im;
  memset(&im, 0, sizeof im);
  int status = outdir_prepare("hetinv-fig4", dir) != 0;
  if (status == 0 && (recon_truth_create(ctx, sc, &truth) != HETINV_SUCCESS ||
                      recon_imaging_build(ctx, truth, sc, &im) != HETINV_SUCCESS)) {
    status = recon_fail("hetinv-fig4", ctx, sc->name);
  } else if (status == 0 && recon_preset_write(ctx, sc, truth, &im, dir, msg, sizeof msg) < 0) {
    fprintf(stderr, "hetinv-fig4: %s\n", msg);
    status = 1;
  } else if (status == 0) {
    printf("%s: wrote %s/{render.json, reconstruct.json, truth_*.vol}\n", sc->name, dir);
  }
  hetinv_medium_destroy(&truth);
  recon_imaging_release(&im);
  hetinv_context_destroy(&ctx);
  return status;
}

/* A finished cell's record is its cell.csv; its checkpoint would only make
 * a rerun under other settings fail (the library refuses a checkpoint
 * written for another run), so it goes once the cell is stored. */
static void drop_checkpoint(const char *dir) {
  char path[1200];
  snprintf(path, sizeof path, "%s/checkpoint.bin", dir);
  if (remove(path) != 0 && errno != ENOENT) {
    fprintf(stderr, "hetinv-fig4: warning: %s: %s (a rerun under other settings will refuse it)\n", path,
            strerror(errno));
  }
}

/* Simulates, reconstructs and writes one cell's outputs; an interrupted
 * earlier run of the same cell continues from its checkpoint. */
static int run_cell(const recon_scene_t *sc, int64_t threads, bool quiet, experiment_cell_t *cell) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc->seed;
  init.thread_count = threads >= 0 ? (int32_t)threads : sc->threads;
  hetinv_context_t *ctx = NULL;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return recon_fail("hetinv-fig4", NULL, "context");
  double t0 = recon_now();
  hetinv_medium_t *truth = NULL, *rec = NULL;
  recon_imaging_t im;
  memset(&im, 0, sizeof im);
  char msg[2048] = "";
  hetinv_result_t r = recon_truth_create(ctx, sc, &truth);
  if (r == HETINV_SUCCESS) r = recon_imaging_build(ctx, truth, sc, &im);
  if (r == HETINV_SUCCESS && !quiet) {
    printf("%s: %d sources, %d rows, %zu values\n", sc->name, (int)im.emitter_count,
           (int)hetinv_measurements_row_count(im.set), hetinv_measurements_value_count(im.set));
    fflush(stdout);
  }
  if (r == HETINV_SUCCESS) r = recon_simulate(ctx, sc, truth, &im);
  if (r == HETINV_SUCCESS && !quiet) recon_print_in_loss("hetinv-fig4", sc, &im);
  if (r != HETINV_SUCCESS) snprintf(msg, sizeof msg, "%s", hetinv_context_last_error_message(ctx));
  if (r == HETINV_SUCCESS) r = recon_solve(ctx, sc, &im, true, quiet, &rec, NULL, msg, sizeof msg);
  if (r == HETINV_SUCCESS) {
    recon_errors(truth, rec, &cell->errors);
    r = recon_write_outputs(ctx, sc, truth, rec, &cell->errors, msg, sizeof msg);
  }
  cell->seconds = recon_now() - t0;
  if (r != HETINV_SUCCESS) fprintf(stderr, "hetinv-fig4: %s: %s\n", sc->name, msg);
  hetinv_medium_destroy(&rec);
  hetinv_medium_destroy(&truth);
  recon_imaging_release(&im);
  hetinv_context_destroy(&ctx);
  return r == HETINV_SUCCESS ? 0 : 1;
}

/* Gauss–Newton steps from a cell's recovery (polish.h), which replace it. */
static int print_polish(const recon_scene_t *sc, const fig4_options_t *o) {
  polish_options_t po = {.steps = (int32_t)o->polish_steps, .replicates = (int32_t)o->polish_replicates,
                         .fisher_replicates = (int32_t)o->polish_fisher, .fisher_photons = o->polish_fisher_photons,
                         .damping = o->polish_damping, .max_step = o->polish_max_step,
                         .cg_iterations = (int32_t)o->polish_cg};
  polish_report_t rep;
  char msg[1400];
  if (polish_run(sc, o->threads, &po, &rep, msg, sizeof msg) != 0) {
    fprintf(stderr, "hetinv-fig4: %s\n", msg);
    return 1;
  }
  polish_print(sc, &rep);
  polish_release(&rep);
  return 0;
}

/* The run's loss gradient at the truth and at a cell's recovery
 * (gradient_check.h), against the 15 % per voxel. */
static int print_gradient_check(const recon_scene_t *sc, int64_t threads, int32_t replicates) {
  gradient_check_t g;
  char msg[1400];
  if (gradient_check_run(sc, threads, replicates, 0.15, &g, msg, sizeof msg) != 0) {
    fprintf(stderr, "hetinv-fig4: %s\n", msg);
    return 1;
  }
  gradient_check_print(sc, &g);
  gradient_check_release(&g);
  return 0;
}

/* The loss at the truth and at a cell's recovery (fit_check.h), and which
 * one the data prefer. */
static int print_fit_check(const recon_scene_t *sc, int64_t threads, int64_t photons, int32_t replicates) {
  fit_check_t f;
  char msg[1400];
  if (fit_check_run(sc, threads, photons, replicates, &f, msg, sizeof msg) != 0) {
    fprintf(stderr, "hetinv-fig4: %s\n", msg);
    return 1;
  }
  fit_check_print(sc, photons, &f);
  if (fit_check_store(sc, photons, &f) != 0) {
    fprintf(stderr, "hetinv-fig4: %s/fit_check.csv: %s\n", sc->output, strerror(errno));
    return 1;
  }
  return 0;
}

/* The bound of one cell at its truth: printed, its maps written in the
 * cell's folder, its summary into *out. */
static int bound_cell(const recon_scene_t *sc, int64_t threads, int64_t photons, int32_t replicates,
                      bool quiet, experiment_bound_t *out) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = sc->seed;
  init.thread_count = threads >= 0 ? (int32_t)threads : sc->threads;
  hetinv_context_t *ctx = NULL;
  if (hetinv_context_create(&init, &ctx) != HETINV_SUCCESS) return recon_fail("hetinv-fig4", NULL, "context");
  hetinv_medium_t *truth = NULL;
  recon_imaging_t im;
  memset(&im, 0, sizeof im);
  recon_bound_t b;
  memset(&b, 0, sizeof b);
  int status = 0;
  if (recon_truth_create(ctx, sc, &truth) != HETINV_SUCCESS || recon_imaging_build(ctx, truth, sc, &im) != HETINV_SUCCESS) {
    status = recon_fail("hetinv-fig4", ctx, sc->name);
  } else {
    if (!quiet) {
      printf("%s: bound at the truth, %lld photons per emitter, %d replicates\n", sc->name, (long long)photons,
             (int)replicates);
      fflush(stdout);
    }
    status = recon_bound_run("hetinv-fig4", ctx, sc, truth, &im, photons, replicates, true, false, &b);
  }
  if (status == 0) {
    for (int p = 0; p < 3; ++p) {
      out->mean[p] = b.mean[p];
      out->median[p] = b.median[p];
      out->max[p] = b.max[p];
      out->lower_mean[p] = b.lower_mean[p];
    }
    out->positive_definite = b.positive_definite;
    out->seconds = b.seconds;
    out->local_radius = b.local_radii > 0 ? b.local_best : -1;
    for (int p = 0; p < 3; ++p) {
      out->local_mean[p] = b.local_radii > 0 ? b.local_mean[b.local_best][p] : (double)NAN;
      out->local_max[p] = b.local_radii > 0 ? b.local_max[b.local_best][p] : (double)NAN;
    }
  }
  recon_bound_release(&b);
  hetinv_medium_destroy(&truth);
  recon_imaging_release(&im);
  hetinv_context_destroy(&ctx);
  return status;
}

/* A cell's bound: read back from its bound.csv if an earlier run stored
 * it with these settings, else computed (bound_cell) and stored. */
static int stored_bound(const recon_scene_t *sc, int64_t threads, int64_t photons, int32_t replicates, bool quiet,
                        const char *bound_from, experiment_bound_t *b) {
  char key[EXPERIMENT_KEY_SIZE], why[1600];
  if (!experiment_bound_key(sc, photons, replicates, key, sizeof key)) {
    fprintf(stderr, "hetinv-fig4: %s: the bound's key is longer than %d bytes\n", sc->output, EXPERIMENT_KEY_SIZE - 1);
    return 1;
  }
  int found = experiment_bound_load(sc->output, key, b, why, sizeof why);
  /* Another key's record goes before the maps it describes are replaced
   * (computed or copied below). */
  if (found == 0 && experiment_record_drop(sc->output, "bound.csv", why, sizeof why) != 0) found = -1;
  if (found == 0 && bound_from != NULL) {
    /* The same cell's folder in the other run: config<c>_volume<v>. */
    const char *cell = strrchr(sc->output, '/');
    char from[1200];
    snprintf(from, sizeof from, "%s/%s", bound_from, cell ? cell + 1 : sc->output);
    found = experiment_bound_adopt(sc->output, from, key, b, why, sizeof why);
  }
  if (found < 0) {
    fprintf(stderr, "hetinv-fig4: %s\n", why);
    return 1;
  }
  bool stored = found == 1;
  if (stored) {
    if (!quiet) {
      bool local = !b->positive_definite && b->local_radius >= 0;
      const double *mean = local ? b->local_mean : b->mean, *max = local ? b->local_max : b->max;
      printf("%s: bound (stored by an earlier run%s): mean/max sigma_a %.2f/%.2f %%, sigma_s %.2f/%.2f %%, "
             "g %.2f/%.2f %%\n", sc->name, local ? "; local" : "", 100 * mean[0], 100 * max[0], 100 * mean[1],
             100 * max[1], 100 * mean[2], 100 * max[2]);
    }
    return 0;
  }
  if (bound_cell(sc, threads, photons, replicates, quiet, b) != 0) return 1;
  if (experiment_bound_store(sc->output, key, b) != 0) {
    fprintf(stderr, "hetinv-fig4: %s/bound.csv: %s\n", sc->output, strerror(errno));
    return 1;
  }
  return 0;
}

/* The cells and the tables: 0, or 1 after a message. */
static int run(const fig4_options_t *o) {
  double table_mean[5][3] = {{0}}, table_max[5][3] = {{0}}, seconds[5] = {0};
  double bound_mean[5][3] = {{0}}, bound_max[5][3] = {{0}}, bound_seconds[5] = {0};
  int bound_pd[5] = {0}, bound_local[5] = {-1, -1, -1, -1, -1}; /* the smallest local radius */
  experiment_verdict_t verdict[5];
  memset(verdict, 0, sizeof verdict);
  bool verdict_ok[5] = {false, true, true, true, true};
  double t_all = recon_now();
  for (int c = 1; c <= 4; ++c) {
    if (!o->configs[c]) continue;
    for (int64_t v = o->first_volume; v < o->first_volume + o->volumes; ++v) {
      recon_scene_t sc;
      make_scene(&sc, o, c, (int)v);
      char msg[512];
      if (recon_scene_check(&sc, msg, sizeof msg) < 0) {
        fprintf(stderr, "hetinv-fig4: %s\n", msg);
        return 1;
      }
      if (outdir_prepare("hetinv-fig4", sc.output) != 0) return 1;
      if (o->write_scenes) {
        if (write_cell_scene(&sc) != 0) return 1;
        continue;
      }
      bool local_bound = false; /* this cell's bound is the local one */
      if (o->bound || o->bound_only) {
        experiment_bound_t b;
        if (stored_bound(&sc, o->threads, o->bound_photons > 0 ? o->bound_photons : sc.photons, (int32_t)o->bound_replicates,
                         o->quiet, o->bound_from, &b) != 0) {
          return 1;
        }
        /* Where F̂ is not positive definite, the local bound stands in
         * (a lower bound of the bound; the table says so). */
        bool local = !b.positive_definite && b.local_radius >= 0;
        local_bound = local;
        if (local && (bound_local[c] < 0 || b.local_radius < bound_local[c])) bound_local[c] = b.local_radius;
        for (int p = 0; p < 3; ++p) {
          double mean = local ? b.local_mean[p] : b.mean[p], max = local ? b.local_max[p] : b.max[p];
          bound_mean[c][p] += mean / (double)o->volumes;
          if (!(max <= bound_max[c][p])) bound_max[c][p] = max; /* NaN propagates */
        }
        bound_seconds[c] += b.seconds;
        bound_pd[c] += b.positive_definite;
        if (o->bound_only) continue;
      }
      char key[EXPERIMENT_KEY_SIZE], why[1600];
      if (!experiment_cell_key(&sc, key, sizeof key)) {
        fprintf(stderr, "hetinv-fig4: %s: the cell's key is longer than %d bytes\n", sc.output, EXPERIMENT_KEY_SIZE - 1);
        return 1;
      }
      experiment_cell_t cell;
      int found = experiment_cell_load(sc.output, key, &cell, why, sizeof why);
      if (found < 0) {
        fprintf(stderr, "hetinv-fig4: %s\n", why);
        return 1;
      }
      bool reused = found == 1;
      /* Another key's record goes first: this cell's files are about to be replaced. */
      if (!reused && experiment_record_drop(sc.output, "cell.csv", why, sizeof why) != 0) {
        fprintf(stderr, "hetinv-fig4: %s\n", why);
        return 1;
      }
      if (!reused && run_cell(&sc, o->threads, o->quiet, &cell) != 0) return 1;
      if (!reused && experiment_cell_store(sc.output, key, &cell) != 0) {
        fprintf(stderr, "hetinv-fig4: %s/cell.csv: %s\n", sc.output, strerror(errno));
        return 1;
      }
      if (!reused) drop_checkpoint(sc.output);
      for (int p = 0; p < 3; ++p) {
        table_mean[c][p] += cell.errors.mean[p] / (double)o->volumes;
        if (cell.errors.max[p] > table_max[c][p]) table_max[c][p] = cell.errors.max[p];
      }
      seconds[c] += cell.seconds;
      if (!o->quiet) {
        const recon_errors_t *e = &cell.errors;
        printf("%s: mean/max relative error: sigma_a %.1f/%.1f %%, sigma_s %.1f/%.1f %%, g %.1f/%.1f %% (%.0f s%s)\n",
               sc.name, 100 * e->mean[0], 100 * e->max[0], 100 * e->mean[1], 100 * e->max[1], 100 * e->mean[2],
               100 * e->max[2], cell.seconds, reused ? ", stored by an earlier run" : "");
        fflush(stdout);
      }
      if (o->bound && verdict_ok[c] && experiment_verdict_add(sc.output, local_bound, &verdict[c], msg, sizeof msg) != 0) {
        fprintf(stderr, "hetinv-fig4: %s: no per-voxel target check for this configuration: %s\n", sc.name, msg);
        verdict_ok[c] = false;
      }
      if (o->fit && print_fit_check(&sc, o->threads, o->fit_photons, (int32_t)o->fit_replicates) != 0) return 1;
      if (o->polish_replicates > 0 && print_polish(&sc, o) != 0) return 1;
      if (o->gradient_replicates > 0 && print_gradient_check(&sc, o->threads, (int32_t)o->gradient_replicates) != 0) {
        return 1;
      }
    }
  }
  if (o->write_scenes) return 0;
  int status = 0;
  if (!o->bound_only) status = error_table(o->out, o->full, o->volumes, o->configs, table_mean, table_max, seconds);
  if ((o->bound || o->bound_only) &&
      bound_table(o->out, o->volumes, o->configs, bound_mean, bound_max, bound_pd, bound_local, bound_seconds,
                  o->bound_only ? NULL : table_mean) != 0) {
    status = 1;
  }
  if (o->bound && target_table(o->out, o->configs, verdict_ok, table_mean, bound_mean, verdict) != 0) status = 1;
  if (status == 0) printf("total %.0f s\n", recon_now() - t_all);
  return status;
}

int main(int argc, char **argv) {
  fig4_options_t o;
  int parsed = fig4_options_parse(argc, argv, &o);
  if (parsed != 0) return parsed == 1 ? 0 : 2;
  /* Before any simulation: a folder we can write, locked for this run
   * (released by the kernel however the process ends). The same command
   * continues an interrupted run, so the record always resumes. */
  outdir_t dir;
  if (outdir_open(&dir, "hetinv-fig4", o.out) != 0) return 1;
  run_record_t record;
  if (run_record_begin(&record, "hetinv-fig4", o.out, argc, argv, true) != 0) {
    outdir_close(&dir);
    return 1;
  }
  interrupted_hint("hetinv-fig4: stopped; the same command continues: finished cells are read back, the "
                   "interrupted one resumes from its checkpoint");
  int status = run(&o);
  if (outdir_finish_stdout("hetinv-fig4") != 0) status = 1;
  status = run_record_end(&record, status);
  outdir_close(&dir);
  return status;
}
