/* Shared helpers of the gradient validation tests (test_gradient_*.c), on
 * top of validation.h.
 *
 * Several gradient references are themselves Monte Carlo estimates whose
 * standard error comes from a modest number of independent repetitions
 * (M random streams), not from the estimator's 256 batch means. A z-score
 * built from such an error is Student-t distributed, not normal; these
 * helpers give the matching Bonferroni threshold, with the
 * Welch–Satterthwaite effective degrees of freedom of a sum of two
 * variance estimates, so that every comparison keeps the family-wise
 * false-alarm probability VAL_FAMILY_ALPHA of validation.h. */
#ifndef HETINV_TEST_GRADIENT_COMMON_H
#define HETINV_TEST_GRADIENT_COMMON_H

#include "validation.h"

/* Degrees of freedom of a standard error from VAL_BATCHES batch means. */
#define GRAD_BATCH_DOF ((double)(VAL_BATCHES - 1))

/* Two-sided tail P(|T| > t) of Student's t with dof degrees of freedom
 * (INFINITY: the normal distribution). */
double grad_t_tail(double t, double dof);

/* t with P(|T_dof| > t) = VAL_FAMILY_ALPHA / comparisons. */
double grad_t_max(double dof, int comparisons);

/* Welch–Satterthwaite: effective dof of se1² + se2², each estimated with
 * dof1 and dof2 degrees of freedom (an exact reference: se2 = 0). */
double grad_welch_dof(double se1, double dof1, double se2, double dof2);

/* Compares est ± se (dof est_dof) with ref ± ref_se (dof ref_dof): z in
 * units of the combined error, threshold grad_t_max(Welch dof,
 * comparisons). Prints the line
 *   VALIDATION GRAD <case> ref=... ref_se=... est=... se=... z=... zmax=... seed=... PASS|FAIL
 * and returns 1 if |z| <= zmax. */
int grad_compare(const char *case_name, double ref, double ref_se, double ref_dof, double est,
                 double se, double est_dof, int comparisons, uint64_t seed);

/* Mean and standard error of the mean of n >= 2 samples. */
void grad_mean_se(const double *x, int n, double *mean, double *se);

/* Deterministic uniform in [0, 1) (SplitMix64), for fixed test media. */
double grad_uniform(uint64_t *state);

/* Wall-clock seconds (for the timings the tests print). */
double grad_now(void);

/* A committed copy of @p base with one parameter of one voxel replaced. */
hetinv_medium_t *grad_perturbed(const hetinv_medium_t *base, const int32_t voxel[3],
                                hetinv_param_t param, double value);

/* The estimator of CRN finite differences: photons_all_streams (scaled by
 * HETINV_VALIDATION_SCALE, at least 64 a stream) spread over `streams`
 * renders, in 2 batches each (the streams, not the batches, give the error). */
hetinv_estimator_t *grad_fd_estimator(hetinv_context_t *ctx, double photons_all_streams, int streams);

/* CRN central differences of the `values` values of `set` with respect to
 * each parameter p of one voxel: stream j < `streams` renders both sides,
 * base ± h[p], so their noise largely cancels (h: 0.05 for g, a tenth of
 * the value otherwise). Writes mean[p·values + n] and se[p·values + n]
 * over the streams, and h[p]. */
void grad_fd_voxel(hetinv_estimator_t *fd_est, const hetinv_medium_t *m, const hetinv_measurements_t *set,
                   const int32_t voxel[3], int values, int streams, double *mean, double *se,
                   double h[HETINV_PARAM_COUNT]);

#endif
