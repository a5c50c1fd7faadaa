/* Shared helpers of the Monte Carlo validation tests.
 *
 * A validation test compares an estimate with a reference within a fixed
 * number of standard errors, z_max, never with a hand-widened tolerance:
 *   z = (estimate - reference) / sqrt(se_estimate² + se_reference²),
 * se_reference being the reference's stated precision (e.g. half a unit in
 * its last given digit). z_max comes from the number of comparisons a test
 * program makes (val_z_max): a Bonferroni bound, so that a correct estimator
 * fails a program with probability < VAL_FAMILY_ALPHA whatever its size.
 *
 * Every comparison prints one greppable line
 *   VALIDATION <case> <quantity> ref=... est=... se=... z=... zmax=... seed=... PASS|FAIL
 * so the results can be quoted as a table; a failing line carries the seed
 * that replays it.
 *
 * HETINV_VALIDATION_SCALE (a compile definition set by CMake) multiplies
 * every photon count: 0.05 in the sanitizer build, 1.0 in the Release build.
 * Every comparison stays a valid test at any scale, since it is made in
 * units of the estimate's own error bar. */
#ifndef HETINV_VALIDATION_H
#define HETINV_VALIDATION_H

#include "test_support.h"

#ifndef HETINV_VALIDATION_SCALE
#error "HETINV_VALIDATION_SCALE must be defined (tests/validation/CMakeLists.txt)"
#endif

#define VAL_PI 3.14159265358979323846

/* Family-wise false-alarm probability of one test program. */
#define VAL_FAMILY_ALPHA 1e-3

/* Batches of every render: 256 batch means make each standard error good
 * to ~4.4 % (1/sqrt(2·255)), so z is close to normal (Student t, 255 dof). */
#define VAL_BATCHES 256

/* Two-sided normal quantile z with P(|Z| > z) = VAL_FAMILY_ALPHA / comparisons. */
double val_z_max(int comparisons);

/* The seed of a test: @p fixed, unless the environment variable
 * HETINV_VALIDATION_SEED holds another (to replay a failure or to look at
 * the spread of z over seeds). */
uint64_t val_seed(uint64_t fixed);

/* The same for a Student t statistic with @p dof degrees of freedom: for
 * comparisons whose error bar is the spread of a few independent replicas. */
double val_t_max(int dof, int comparisons);
/* Regularised incomplete beta function I_x(a, b) (Student-t tails). */
double val_beta_inc(double a, double b, double x);

/* Photon count full·HETINV_VALIDATION_SCALE, rounded, at least 32. */
double val_photons(double full);

/* A context with the given seed and thread count (1 unless a test is about threads). */
hetinv_context_t *val_context(uint64_t seed, int32_t threads);

/* An estimator with val_photons(full_photons) photons and VAL_BATCHES batches. */
hetinv_estimator_t *val_estimator(hetinv_context_t *ctx, double full_photons);

/* A medium of box [lo, hi] and dims, filled with (sigma_a, sigma_s, g) and
 * indices eta / eta_out; committed unless @p commit is false. */
hetinv_medium_t *val_medium(hetinv_context_t *ctx, const double lo[3], const double hi[3],
                            const int32_t dims[3], double sigma_a, double sigma_s, double g,
                            double eta, double eta_out, int commit);

/* Ranges of a heterogeneous medium's voxel values: each voxel draws σa, σs
 * and g uniformly in [lo, hi] from a hash of (pattern, voxel index). */
typedef struct val_ranges {
  double sigma_a[2], sigma_s[2], g[2];
} val_ranges_t;

/* An uncommitted heterogeneous medium of box [lo, hi] and dims, with values
 * drawn as val_ranges_t says, and indices eta / eta_out. */
hetinv_medium_t *val_heterogeneous(hetinv_context_t *ctx, const double lo[3], const double hi[3],
                                   const int32_t dims[3], const val_ranges_t *ranges,
                                   uint64_t pattern, double eta, double eta_out);

/* splitmix64: a small deterministic generator for the tests' own choices
 * (voxel values, sample directions). */
uint64_t val_splitmix64(uint64_t *state);
/* Uniform in [0, 1) from val_splitmix64. */
double val_uniform(uint64_t *state);

/* Prints the VALIDATION line of one comparison and returns 1 if |z| <= z_max.
 * ref_se is the reference's own precision (0 for an exact reference). */
int val_compare(const char *case_id, const char *quantity, double ref, double ref_se, double est,
                double se, double z_max, uint64_t seed);

/* Prints a VALIDATION line for an exact check (|est - ref| <= tol) and
 * returns 1 if it holds. */
int val_check_exact(const char *case_id, const char *quantity, double ref, double est, double tol,
                    uint64_t seed);

/* Prints an informational line (a figure quoted, not tested). */
void val_note(const char *case_id, const char *quantity, double value, double se);

/* Fails the current cmocka test if any comparison failed. */
#define val_assert_all_passed(failures) \
  do { \
    if ((failures) != 0) { \
      print_error("%d comparison(s) failed; see the VALIDATION ... FAIL lines\n", (failures)); \
      fail(); \
    } \
  } while (0)

#endif
