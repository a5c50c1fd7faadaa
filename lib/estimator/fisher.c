/* The Fisher information of the free parameters and the Cramér–Rao bound.
 *
 * F = Jᵀ W J with W = diag(mask_n / variance_n). Each replicate r forms J
 * column by column from one tangent pass with the K one-hot tangents
 * (jvp.c: J·e_k for every k in one pass over the photons, i.e. J itself),
 * twice, on the independent streams s + 2r and s + 2r + 1:
 * F_r = ½(Ĵ₁ᵀ W Ĵ₂ + Ĵ₂ᵀ W Ĵ₁). The two factors share no photon, so
 * E[F_r] = E[Ĵ₁]ᵀ W E[Ĵ₂] = F exactly (Ĵ₁ᵀ W Ĵ₁ would add the Monte Carlo
 * variance of J to F and bias the bound low). The replicates are
 * independent: their mean is the estimate, their spread its error. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "core/rng.h"
#include "estimator/fisher_internal.h"
#include "estimator/pass.h"
#include "estimator/spd.h"
#include "hetinv/bound.h"
#include "medium/medium_internal.h"
#include "param/param_map_internal.h"
#include "sampling/measurements_internal.h"

hetinv_result_t hv_fisher_check(const hv_pass_t *pass, const hetinv_medium_t *medium,
                                const hetinv_measurements_t *set, const double *variances,
                                const hetinv_param_map_t *map, int32_t replicates,
                                const char *replicates_name, size_t k, bool dense,
                                double **weights) {
  const hetinv_context_t *ctx = pass->ctx;
  hetinv_result_t r = hv_check_pi_map(ctx, map, medium, k, "k");
  if (r != HETINV_SUCCESS) return r;
  if (dense && k > HETINV_FISHER_MAX_ENTRIES) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the map has %zu entries; the dense Fisher matrix takes at most %d", k,
                   HETINV_FISHER_MAX_ENTRIES);
  }
  if (replicates < 2 || replicates > HETINV_FISHER_MAX_REPLICATES) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "%s is %d; expected an integer from 2 to %d", replicates_name,
                   (int)replicates, HETINV_FISHER_MAX_REPLICATES);
  }
  size_t n = set->value_count;
  double *w = hv_calloc(ctx, n, sizeof(double));
  if (w == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu weights", n);
  for (size_t i = 0; i < n; ++i) {
    if (!set->mask[i]) continue;
    double var = variances ? variances[i] : set->std_errors[i] * set->std_errors[i];
    if (!(isfinite(var) && var > 0.0)) {
      hv_free(ctx, w);
      return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "the variance of value %zu is %g (%s); a value in the mask needs a finite "
                     "positive variance", i, var,
                     variances ? "variances[]" : "the set's standard error squared");
    }
    w[i] = 1.0 / var;
  }
  *weights = w;
  return HETINV_SUCCESS;
}

/* Rows of G per tile and values per block of the product below: a tile
 * of G (32 rows of K ≤ 2048 doubles, 512 KiB) stays in cache while a
 * block of values streams through it. */
#define PRODUCT_TILE 32
#define PRODUCT_BLOCK 256

/* F = ½(G + Gᵀ) with G = ĴaᵀWĴb = Σ_n w_n a_n b_nᵀ (a_n, b_n: row n of the
 * two count×K Jacobians), blocked like a matrix product and parallel over
 * tiles of G's rows; each entry sums the values in order, so the result
 * does not depend on the thread count. Zero weights (masked values) and
 * zero entries of a_n (voxels the value's paths never saw) are skipped. */
static void product(const double *ja, const double *jb, const double *w, size_t count, size_t K,
                    int threads, double *F) {
  (void)threads; /* without OpenMP */
  memset(F, 0, K * K * sizeof(double));
  const long tiles = (long)((K + PRODUCT_TILE - 1) / PRODUCT_TILE);
  for (size_t n0 = 0; n0 < count; n0 += PRODUCT_BLOCK) {
    size_t n1 = n0 + PRODUCT_BLOCK < count ? n0 + PRODUCT_BLOCK : count;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic) num_threads(threads)
#endif
    for (long tile = 0; tile < tiles; ++tile) {
      size_t i0 = (size_t)tile * PRODUCT_TILE, i1 = i0 + PRODUCT_TILE < K ? i0 + PRODUCT_TILE : K;
      for (size_t n = n0; n < n1; ++n) {
        if (w[n] == 0.0) continue;
        const double *a = ja + n * K, *b = jb + n * K;
        for (size_t i = i0; i < i1; ++i) {
          double ai = w[n] * a[i];
          if (ai == 0.0) continue;
          double *row = F + i * K;
          for (size_t j = 0; j < K; ++j) row[j] += ai * b[j];
        }
      }
    }
  }
  for (size_t i = 0; i < K; ++i) { /* symmetric exactly */
    for (size_t j = i; j < K; ++j) {
      double x = 0.5 * (F[i * K + j] + F[j * K + i]);
      F[i * K + j] = F[j * K + i] = x;
    }
  }
}

/* The R replicates F_r, each K·K, into reps. */
static hetinv_result_t replicates_of(const hv_pass_t *pass, const hetinv_param_map_t *map,
                                     const double *w, size_t count, int32_t R, size_t K,
                                     double *reps) {
  const hetinv_context_t *ctx = pass->ctx;
  size_t V = (size_t)pass->grid.n[0] * (size_t)pass->grid.n[1] * (size_t)pass->grid.n[2];
  size_t nj = 0, nt = 0;
  if (!hv_mul_size(count, K, &nj) || !hv_mul_size(3 * V, K, &nt)) {
    return HV_FAIL(ctx, HETINV_ERROR_SIZE_OVERFLOW, "%zu values or %zu voxels times %zu entries overflow",
                   count, V, K);
  }
  double *eye = hv_calloc(ctx, K * K, sizeof(double));
  double *tangent = hv_calloc(ctx, nt, sizeof(double));
  double *j1 = hv_calloc(ctx, nj, sizeof(double)), *j2 = hv_calloc(ctx, nj, sizeof(double));
  hetinv_result_t r = HETINV_SUCCESS;
  if (!(eye && tangent && j1 && j2)) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                "cannot allocate the Jacobian of %zu values by %zu entries", count, K);
  }
  if (r == HETINV_SUCCESS) {
    for (size_t i = 0; i < K; ++i) eye[i * K + i] = 1.0;
    hv_param_map_pushforward(map, eye, (int32_t)K, tangent);
  }
  for (int32_t rep = 0; r == HETINV_SUCCESS && rep < R; ++rep) {
    hv_pass_t p = *pass;
    p.stream = (uint32_t)((pass->stream + 2u * (uint32_t)rep) % HV_RNG_STREAM_LIMIT);
    r = hv_tangent_run(&p, tangent, (int32_t)K, count, j1, NULL);
    if (r != HETINV_SUCCESS) break;
    p.stream = (p.stream + 1u) % HV_RNG_STREAM_LIMIT;
    r = hv_tangent_run(&p, tangent, (int32_t)K, count, j2, NULL);
    if (r != HETINV_SUCCESS) break;
    product(j1, j2, w, count, K, pass->threads, reps + (size_t)rep * K * K);
  }
  hv_free(ctx, eye);
  hv_free(ctx, tangent);
  hv_free(ctx, j1);
  hv_free(ctx, j2);
  return r;
}

/* Begins the pass, checks, and computes the replicates (allocated into *reps). */
static hetinv_result_t fisher_run(hetinv_estimator_t *est, const hetinv_medium_t *medium,
                                  const hetinv_measurements_t *set, const double *variances,
                                  size_t count, const hetinv_param_map_t *map, int32_t R, size_t k,
                                  double **reps) {
  hv_pass_t pass;
  *reps = NULL;
  hetinv_result_t r = hv_pass_begin(est, medium, set, count, &pass);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = pass.ctx;
  double *w = NULL;
  r = hv_fisher_check(&pass, medium, set, variances, map, R, "replicates", k, true, &w);
  if (r == HETINV_SUCCESS) {
    *reps = hv_calloc(ctx, (size_t)R * k * k, sizeof(double));
    if (*reps == NULL) {
      r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %d matrices of %zu x %zu",
                  (int)R, k, k);
    }
  }
  if (r == HETINV_SUCCESS) r = replicates_of(&pass, map, w, count, R, k, *reps);
  if (r != HETINV_SUCCESS) {
    hv_free(ctx, *reps);
    *reps = NULL;
  }
  hv_free(ctx, w);
  hv_pass_end(&pass);
  return r;
}

HETINV_API hetinv_result_t hetinv_estimator_fisher(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t replicates,
    double *fisher, double *fisher_std_errors, size_t k) {
  HV_API_ENTER();
  if (estimator && fisher == NULL) {
    return HV_FAIL(estimator->ctx, HETINV_ERROR_NULL_ARGUMENT, "'fisher' is NULL");
  }
  double *reps = NULL;
  hetinv_result_t r = fisher_run(estimator, medium, set, variances, count, map, replicates, k,
                                 &reps);
  if (r != HETINV_SUCCESS) return r;
  size_t kk = k * k;
  for (size_t i = 0; i < kk; ++i) {
    double sum = 0.0, sq = 0.0;
    for (int32_t rep = 0; rep < replicates; ++rep) sum += reps[(size_t)rep * kk + i];
    double mean = sum / replicates;
    for (int32_t rep = 0; rep < replicates; ++rep) {
      double d = reps[(size_t)rep * kk + i] - mean;
      sq += d * d;
    }
    fisher[i] = mean;
    if (fisher_std_errors) fisher_std_errors[i] = sqrt(sq / (replicates - 1) / replicates);
  }
  hv_free(estimator->ctx, reps);
  return HETINV_SUCCESS;
}

/* CRB standard deviations of the entries in `keep` (m of them) from the
 * K×K matrix F; false if F restricted to them is not positive definite. */
static bool crb_of(const double *F, size_t K, const size_t *keep, size_t m, double *A,
                   double *scratch, double *sd) {
  for (size_t i = 0; i < m; ++i) {
    for (size_t j = 0; j < m; ++j) A[i * m + j] = F[keep[i] * K + keep[j]];
  }
  if (!hv_spd_inverse_diagonal(A, m, scratch, sd)) return false;
  for (size_t i = 0; i < m; ++i) sd[i] = sqrt(sd[i]);
  return true;
}

HETINV_API hetinv_result_t hetinv_estimator_crb(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t replicates,
    double *sd, double *sd_std_errors, double *sd_lower, size_t k, int32_t *positive_definite) {
  HV_API_ENTER();
  if (estimator && sd == NULL) return HV_FAIL(estimator->ctx, HETINV_ERROR_NULL_ARGUMENT, "'sd' is NULL");
  double *reps = NULL;
  hetinv_result_t r = fisher_run(estimator, medium, set, variances, count, map, replicates, k,
                                 &reps);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = estimator->ctx;
  int32_t R = replicates;
  size_t kk = k * k;
  double *mean = hv_calloc(ctx, kk, sizeof(double)), *loo = hv_calloc(ctx, kk, sizeof(double));
  double *A = hv_calloc(ctx, kk, sizeof(double)), *scratch = hv_calloc(ctx, 2 * k, sizeof(double));
  double *sub = hv_calloc(ctx, k, sizeof(double)), *jk = hv_calloc(ctx, (size_t)R * k, sizeof(double));
  size_t *keep = hv_calloc(ctx, k, sizeof(size_t));
  if (!(mean && loo && A && scratch && sub && jk && keep)) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the inverse of %zu x %zu", k, k);
  }
  if (r == HETINV_SUCCESS) {
    for (int32_t rep = 0; rep < R; ++rep) {
      for (size_t i = 0; i < kk; ++i) mean[i] += reps[(size_t)rep * kk + i];
    }
    for (size_t i = 0; i < kk; ++i) mean[i] /= R;
    /* Entries that no replicate saw at all (no path reaches them, or the
     * mask hides every value they touch) carry no information: infinite
     * bound, and they are left out of the inversion. */
    size_t m = 0;
    for (size_t i = 0; i < k; ++i) {
      bool seen = false;
      for (int32_t rep = 0; rep < R && !seen; ++rep) seen = reps[(size_t)rep * kk + i * k + i] != 0.0;
      if (seen) keep[m++] = i;
      sd[i] = (double)INFINITY;
      if (sd_std_errors) sd_std_errors[i] = 0.0;
      if (sd_lower) sd_lower[i] = mean[i * k + i] > 0.0 ? 1.0 / sqrt(mean[i * k + i]) : (seen ? (double)NAN : (double)INFINITY);
    }
    bool pd = crb_of(mean, k, keep, m, A, scratch, sub);
    if (positive_definite) *positive_definite = pd;
    for (size_t i = 0; i < m; ++i) sd[keep[i]] = pd ? sub[i] : (double)NAN;
    /* Jackknife over the replicates: F without replicate r is
     * (R·F̄ − F_r)/(R − 1). */
    bool jk_ok = pd;
    for (int32_t rep = 0; jk_ok && sd_std_errors && rep < R; ++rep) {
      for (size_t i = 0; i < kk; ++i) loo[i] = (R * mean[i] - reps[(size_t)rep * kk + i]) / (R - 1);
      jk_ok = crb_of(loo, k, keep, m, A, scratch, jk + (size_t)rep * k);
    }
    for (size_t i = 0; sd_std_errors && i < m; ++i) {
      double avg = 0.0, sq = 0.0;
      for (int32_t rep = 0; rep < R; ++rep) avg += jk[(size_t)rep * k + i];
      avg /= R;
      for (int32_t rep = 0; rep < R; ++rep) {
        double d = jk[(size_t)rep * k + i] - avg;
        sq += d * d;
      }
      sd_std_errors[keep[i]] = jk_ok ? sqrt((R - 1.0) / R * sq) : (double)NAN;
    }
  }
  hv_free(ctx, reps);
  hv_free(ctx, mean);
  hv_free(ctx, loo);
  hv_free(ctx, A);
  hv_free(ctx, scratch);
  hv_free(ctx, sub);
  hv_free(ctx, jk);
  hv_free(ctx, keep);
  return r;
}

void hv_fisher_mean_se(const double *sum, const double *sq, size_t n, int32_t R, double *mean, double *se) {
  for (size_t i = 0; i < n; ++i) {
    double m = sum[i] / R;
    mean[i] = m;
    if (se) {
      double var = (sq[i] - R * m * m) / (R - 1);
      se[i] = sqrt(var > 0.0 ? var / R : 0.0);
    }
  }
}

double hv_fisher_rademacher(uint64_t seed, int32_t probe, size_t i) {
  uint64_t z = seed ^ ((uint64_t)(uint32_t)probe * 0x9e3779b97f4a7c15ULL) ^ ((uint64_t)i * 0xd1b54a32d192ed03ULL);
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return (z >> 63) ? 1.0 : -1.0;
}

HETINV_API hetinv_result_t hetinv_estimator_fisher_diagonal(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t probes,
    double *diagonal, double *diagonal_std_errors, size_t k) {
  HV_API_ENTER();
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, count, &pass);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = pass.ctx;
  double *w = NULL;
  if (diagonal == NULL) r = HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'diagonal' is NULL");
  if (r == HETINV_SUCCESS) r = hv_fisher_check(&pass, medium, set, variances, map, probes, "probes", k, false, &w);
  double *z = NULL, *tangent = NULL, *jz = NULL, *g = NULL, *sum = NULL, *sq = NULL;
  if (r == HETINV_SUCCESS) {
    z = hv_calloc(ctx, k, sizeof(double));
    tangent = hv_calloc(ctx, 3 * medium->voxel_count, sizeof(double));
    jz = hv_calloc(ctx, count, sizeof(double));
    g = hv_calloc(ctx, k, sizeof(double));
    sum = hv_calloc(ctx, k, sizeof(double));
    sq = hv_calloc(ctx, k, sizeof(double));
    if (!(z && tangent && jz && g && sum && sq)) {
      r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the probes of %zu entries", k);
    }
  }
  for (int32_t probe = 0; r == HETINV_SUCCESS && probe < probes; ++probe) {
    /* d = z ⊙ Ĵ₂ᵀ W Ĵ₁ z, the two passes on independent streams:
     * E[d_k] = Σ_j F_kj E[z_k z_j] = F_kk. */
    for (size_t i = 0; i < k; ++i) z[i] = hv_fisher_rademacher(pass.seed, probe, i);
    hv_param_map_pushforward(map, z, 1, tangent);
    hv_pass_t p = pass;
    p.stream = (uint32_t)((pass.stream + 2u * (uint32_t)probe) % HV_RNG_STREAM_LIMIT);
    r = hv_tangent_run(&p, tangent, 1, count, jz, NULL);
    if (r != HETINV_SUCCESS) break;
    for (size_t n = 0; n < count; ++n) jz[n] *= w[n];
    p.stream = (p.stream + 1u) % HV_RNG_STREAM_LIMIT;
    r = hv_gradient_run(&p, map, jz, g, NULL);
    for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) {
      double d = z[i] * g[i];
      sum[i] += d;
      sq[i] += d * d;
    }
  }
  if (r == HETINV_SUCCESS) hv_fisher_mean_se(sum, sq, k, probes, diagonal, diagonal_std_errors);
  hv_free(ctx, w);
  hv_free(ctx, z);
  hv_free(ctx, tangent);
  hv_free(ctx, jz);
  hv_free(ctx, g);
  hv_free(ctx, sum);
  hv_free(ctx, sq);
  hv_pass_end(&pass);
  return r;
}
