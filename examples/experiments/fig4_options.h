/* hetinv-fig4's command line: what it asks for, checked, and the settings
 * it overrides in each cell's scene. */
#ifndef FIG4_OPTIONS_H
#define FIG4_OPTIONS_H

#include <stdbool.h>
#include <stdint.h>

#include "recon.h"

/* Room a cell's folder name takes after -o's (and --bound-from's) path:
 * "/config4_volume100" and spare. */
#define FIG4_CELL_FOLDER_MAX 32

/* -1 (or NULL) where the option was not given: the scene's default. */
typedef struct fig4_options {
  bool full, quiet, write_scenes, configs[5]; /* configs[1..4] */
  bool bound, bound_only, init_truth, init_geometric, fit, stage_results;
  bool independent_errors, pooled_errors, expected_camera_errors, residual_weights;
  const char *bound_from, *out;
  int64_t first_volume, volumes; /* volumes first_volume + 1 .. first_volume + volumes */
  int64_t iterations, photons, minibatch, grid, threads, truth_photons, coarse_window, seed;
  int64_t bound_photons, bound_replicates, fit_photons, fit_replicates;
  int64_t gradient_replicates; /* --gradient-check N; 0: none */
  /* --polish N (gradients per step; 0: none), --polish-steps, --polish-fisher, --polish-fisher-photons, --polish-damping, --polish-max-step, --polish-cg */
  int64_t polish_replicates, polish_steps, polish_fisher, polish_fisher_photons, polish_cg;
  double polish_damping, polish_max_step;
  double scale, epsilon, min_snr, decay, coarse_fraction, epsilon_start, coarse_epsilon_start, settle_epsilon, settle_fraction, settle_photons, loss_clip, smoothness, multiscale, box_margin;
  double rate, beta1, beta2; /* --rate: SGD, AdaGrad and Adam's step size; --beta1, --beta2: Adam's decays */
  int coordinates, method, loss_clip_errors, min_snr_errors;
  /* --coarse-levels: the coarser stages' cells per axis, increasing; -1:
   * the scene's schedule, 0: none (the finest level alone). */
  int32_t coarse_level_count, coarse_levels[RECON_MAX_LEVELS - 1];
} fig4_options_t;

/* Reads argv into *o: 0 to run, 1 if it printed the help, 2 after printing
 * what is wrong with the command line and the usage. */
int fig4_options_parse(int argc, char **argv, fig4_options_t *o);

/* Sets in a cell's scene the settings the command line overrides
 * (make_scene takes the others). */
void fig4_options_apply(const fig4_options_t *o, recon_scene_t *sc);

#endif
