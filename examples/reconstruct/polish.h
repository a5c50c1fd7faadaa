/* Gauss–Newton polish of a finished recovery: steps that solve the data's
 * own curvature instead of stepping each entry on its own.
 *
 * The gradient check's dᵀF d shows full-size recoveries 2–10 times further
 * from their truth than their data's noise explains, also from a start at
 * the truth: the stochastic step wanders along directions the data
 * constrain weakly, where a per-entry step moves slowly and averaging its
 * iterates does not reach the minimum. Newton's step on the Gauss–Newton
 * model moves every direction at the rate its curvature asks:
 *
 *   (2F̂ + H_prior + μ·diag) δ = −(ĝ + ∇prior),   π ← clip(π + δ, box)
 *
 * with F̂ = JᵀWJ the Fisher matrix of the run's loss weights W at the
 * recovery (hetinv_estimator_fisher(), unbiased, from independent photon
 * streams; 2F̂ is the loss's Gauss–Newton Hessian), H_prior the smoothness
 * prior's exact Hessian, ĝ the mean of `replicates` independent gradients
 * of the run's loss over every source (the run's photons, clip and gain
 * mode) and μ a Levenberg–Marquardt damping raised (×4) until the matrix
 * factors; a step longer than the trust region is shortened to it. Where
 * the loss is nearly quadratic one step reaches the minimum up to ĝ's Monte
 * Carlo error, which A⁻¹ carries into π: more replicates shrink it as 1/√R.
 * F̂'s own noise changes the path, not the point it converges to (ĝ = 0
 * there). Every entry of the finest grid is free (the identity map, native
 * coordinates). Measured at the paper's size in docs/results/fig4.md
 * (fifteenth sitting): not a remedy there. */
#ifndef HETINV_RECON_POLISH_H
#define HETINV_RECON_POLISH_H

#include <stddef.h>
#include <stdint.h>

#include "recon.h"

/* Streams: step s's gradients take 2·(s·replicates + j) from 62000, F̂'s
 * replicates 2r from 64000; both stay within the estimator's 65535. */
#define POLISH_MAX_GRADIENTS 999 /* steps × replicates */
#define POLISH_MAX_FISHER_REPLICATES 767

typedef struct polish_options {
  int32_t steps;             /* Gauss–Newton steps (≥ 1) */
  int32_t replicates;        /* gradients averaged per step (≥ 2) */
  int32_t fisher_replicates; /* replicates of F̂ (≥ 2), taken once at the start */
  int64_t fisher_photons;    /* photons per source for F̂; 0: the run's */
  double damping;            /* the first μ tried at each step (> 0) */
  int32_t cg_iterations;     /* > 0: a truncated conjugate-gradient solve of at most this many iterations
                              * instead of Cholesky's with μ raised until it factors */
  double max_step;           /* a trust region: δ is shortened to this RMS of the entries' box widths */
} polish_options_t;

/* One step's record. */
typedef struct polish_step {
  double loss, loss_se;  /* the data's loss at the step's start: mean over the replicates, its error */
  double prior;          /* the prior's value there */
  double damping;        /* the μ that factored (Cholesky) or was given (CG) */
  int32_t cg_iterations; /* CG: iterations taken */
  int cg_negative;       /* CG: 1 if a direction of curvature ≤ 0 stopped it */
  double residual;       /* ‖(H + μ·diag H)δ + g‖ ÷ ‖g‖ before the trust region: ~1e-12 for Cholesky */
  double predicted;      /* the model's decrease −(ĝᵀδ + ½δᵀAδ) with A without μ */
  double step_rms;       /* RMS of δ ÷ each entry's box width, before the trust region shortened it */
  size_t clipped;        /* entries the box cut */
  recon_errors_t errors; /* against the truth, after the step */
} polish_step_t;

typedef struct polish_report {
  polish_step_t *steps; /* `count` of them */
  int32_t count;
  recon_errors_t start; /* the stored recovery's errors */
  double fisher_seconds, seconds;
} polish_report_t;

/* Polishes the recovery stored in <scene->output> (recovered_<param>.vol;
 * the data are simulated again as the cell did) and writes the polished
 * one in its place (recon_write_outputs()) with polish.csv, one line per
 * step: run it over a copy of a finished cell. 0, or -1 with
 * "<what or file>: <reason>" in msg. */
int polish_run(const recon_scene_t *scene, int64_t threads, const polish_options_t *options, polish_report_t *out,
               char *msg, size_t msg_size);

void polish_print(const recon_scene_t *scene, const polish_report_t *report);

void polish_release(polish_report_t *report);

#endif
