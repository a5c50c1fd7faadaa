/* Where a cell misses the paper's per-voxel target (15 %), whether its
 * data explain the miss: the rule is "within 15 %, or within 1.5×
 * the bound where the bound itself exceeds it". */
#ifndef HETINV_EXPERIMENT_VERDICT_H
#define HETINV_EXPERIMENT_VERDICT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <hetinv/hetinv.h>

#define VERDICT_MEAN_ERROR 0.07  /* the paper's mean relative error */
#define VERDICT_MAX_ERROR 0.15   /* the paper's max relative error */
#define VERDICT_BOUND_FACTOR 1.5 /* a miss within this × its bound is the data's */
#define VERDICT_RADII 4          /* local bounds' radii looked for in bound.exr */

typedef struct experiment_verdict {
  size_t voxels[3];      /* compared: with a finite, positive bound */
  size_t over[3];        /* of those, error > VERDICT_MAX_ERROR */
  size_t unexplained[3]; /* of those, not within VERDICT_BOUND_FACTOR × a bound over 15 % */
  /* The same counts for an efficient unbiased recovery, whose relative
   * error at each voxel is N(0, bound²): what the data alone would give.
   * The expected counts hold whatever the errors' correlations. */
  double efficient_over[3];        /* E[over] */
  double efficient_unexplained[3]; /* E[unexplained] */
  /* P(every voxel within its allowance) for that recovery lies between
   * exp(efficient_log_meet) (the product over voxels: Šidák's inequality
   * makes it a lower bound for any correlation of Gaussian errors) and
   * 1 - efficient_hardest_miss (the hardest voxel's own probability). */
  double efficient_log_meet[3];
  double efficient_hardest_miss[3];
  /* The achieved errors in units of their bound, z = (recovered - truth) /
   * (truth · bound): Σz (a bias shows as a mean far from 0), Σz² (mean
   * near 1 for an efficient recovery) and max |z|. */
  double z_sum[3], z2_sum[3], z_max[3];
  /* With local bounds whose bound.exr holds every radius computed
   * (bound_local_r<N>_<param>): per radius, the voxels over 15 % not within
   * that radius's allowance, and those over 15 % whose window at that
   * radius is not positive definite (not counted as not within). radii is
   * the fewest radii of the cells added (0: some cell has none). */
  size_t cells;
  int radii;
  size_t radius_unexplained[VERDICT_RADII][3], radius_undetermined[VERDICT_RADII][3];
} experiment_verdict_t;

/* P(|N(0, 1)| > t). */
double experiment_normal_tail2(double t);

/* The expected max |z| of n independent N(0, 1) values, for reading z_max
 * (about 3.5 at n = 1875). */
double experiment_expected_max_abs_normal(size_t n);

/* Prints v's efficient-recovery lines for parameter p under `label`. */
void experiment_verdict_print_efficient(const experiment_verdict_t *v, int p, const char *label);

/* Adds one cell's counts to *v: reads <dir>/truth_<p>.vol,
 * <dir>/recovered_<p>.vol and the bound maps of <dir>/bound.exr (the full
 * bound's channels, or with `local` the local bound's, a lower bound of
 * the bound, so a miss it explains the full bound explains too). Voxels of
 * the bound's section only (the middle of y). 0, or -1 with
 * "<file>: <reason>" in msg. */
/* Counts one voxel of parameter p into *v against a per-voxel target
 * max_error (the relative error) and its relative bound: nothing if the
 * bound is not finite and positive or the truth is 0. */
void experiment_verdict_voxel(experiment_verdict_t *v, int p, double truth, double recovered, double bound,
                              double max_error);

/* A 1-channel .vol into a malloc'd array, its dims in d; NULL with
 * "<path>: <reason>" in msg. */
float *experiment_vol_load(hetinv_context_t *ctx, const char *path, int32_t d[3], char *msg, size_t n);

int experiment_verdict_add(const char *dir, bool local, experiment_verdict_t *v, char *msg, size_t msg_size);

#endif
