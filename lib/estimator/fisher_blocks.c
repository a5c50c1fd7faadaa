/* The blocks of the Fisher matrix on its diagonal, one per cell of the map
 * (hetinv_estimator_fisher_blocks), matrix-free and for any map size.
 *
 * A cell's block is F restricted to its own P free parameters. Probing:
 * the cells are split into classes by their coordinates modulo the
 * spacing, and each probe z puts random signs on ONE parameter p of ONE
 * class's cells, zero elsewhere. Then g = Ĵ₂ᵀ W Ĵ₁ z (a tangent pass and a
 * gradient pass on independent streams) has E[s_{c,p} g_{c,b}] = F_{cb,cp}
 * for each cell c of the class (s its sign): the other cells of the class
 * add terms of random sign, zero in expectation, and only they add noise,
 * so the wider the spacing the smaller the noise (cells far apart share
 * few paths) and the more passes. One tangent pass carries all probes of a
 * replicate (hv_tangent_run takes several tangents); each probe then costs
 * one gradient pass. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "core/rng.h"
#include "estimator/fisher_internal.h"
#include "estimator/pass.h"
#include "hetinv/bound.h"
#include "param/param_map_internal.h"

/* Largest spacing: classes are spacing³ at most. */
#define MAX_SPACING 16

typedef struct probes {
  int32_t dims[3], side[3];
  size_t cells, P, K;
  int32_t classes, T; /* T = classes · P tangents per replicate */
  int32_t *class_of;  /* per cell */
} probes_t;

static hetinv_result_t probes_make(const hetinv_context_t *ctx, const hetinv_param_map_t *map,
                                   size_t k, int32_t spacing, probes_t *pr) {
  memset(pr, 0, sizeof *pr);
  hetinv_param_map_get_dims(map, pr->dims);
  pr->cells = (size_t)pr->dims[0] * (size_t)pr->dims[1] * (size_t)pr->dims[2];
  pr->K = k;
  pr->P = pr->cells ? k / pr->cells : 0;
  pr->classes = 1;
  for (int a = 0; a < 3; ++a) {
    pr->side[a] = spacing < pr->dims[a] ? spacing : pr->dims[a];
    pr->classes *= pr->side[a];
  }
  pr->T = pr->classes * (int32_t)pr->P;
  pr->class_of = hv_calloc(ctx, pr->cells ? pr->cells : 1, sizeof(int32_t));
  if (pr->class_of == NULL) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the classes of %zu cells", pr->cells);
  }
  for (size_t c = 0; c < pr->cells; ++c) {
    int32_t x = (int32_t)(c % (size_t)pr->dims[0]);
    int32_t y = (int32_t)(c / (size_t)pr->dims[0] % (size_t)pr->dims[1]);
    int32_t z = (int32_t)(c / ((size_t)pr->dims[0] * (size_t)pr->dims[1]));
    pr->class_of[c] = x % pr->side[0] + pr->side[0] * (y % pr->side[1] + pr->side[1] * (z % pr->side[2]));
  }
  return HETINV_SUCCESS;
}

/* Probe t = class·P + p of replicate rep into z (K entries). */
static void probe_fill(const probes_t *pr, uint64_t seed, int32_t rep, int32_t t, double *z) {
  int32_t cls = t / (int32_t)pr->P;
  size_t p = (size_t)t % pr->P;
  memset(z, 0, pr->K * sizeof(double));
  for (size_t c = 0; c < pr->cells; ++c) {
    if (pr->class_of[c] != cls) continue;
    size_t i = p * pr->cells + c;
    z[i] = hv_fisher_rademacher(seed, rep * pr->T + t, i);
  }
}

/* One replicate's blocks (cells·P·P, symmetrised) into out. */
static hetinv_result_t replicate(const hv_pass_t *pass, const hetinv_param_map_t *map, const double *w,
                                 size_t count, const probes_t *pr, int32_t rep, double *Z,
                                 double *tangent, double *Y, double *cot, double *g, double *out) {
  const size_t P = pr->P, K = pr->K, T = (size_t)pr->T;
  for (int32_t t = 0; t < pr->T; ++t) probe_fill(pr, pass->seed, rep, t, Z + (size_t)t * K);
  hv_param_map_pushforward(map, Z, pr->T, tangent);
  hv_pass_t p = *pass;
  p.stream = (uint32_t)((pass->stream + 2u * (uint32_t)rep) % HV_RNG_STREAM_LIMIT);
  hetinv_result_t r = hv_tangent_run(&p, tangent, pr->T, count, Y, NULL);
  p.stream = (p.stream + 1u) % HV_RNG_STREAM_LIMIT;
  memset(out, 0, pr->cells * P * P * sizeof(double));
  for (size_t t = 0; r == HETINV_SUCCESS && t < T; ++t) {
    for (size_t n = 0; n < count; ++n) cot[n] = w[n] * Y[n * T + t];
    r = hv_gradient_run(&p, map, cot, g, NULL);
    const double *z = Z + t * K;
    size_t col = t % P;
    for (size_t c = 0; r == HETINV_SUCCESS && c < pr->cells; ++c) {
      double s = z[col * pr->cells + c];
      if (s == 0.0) continue;
      for (size_t b = 0; b < P; ++b) out[(c * P + b) * P + col] = s * g[b * pr->cells + c];
    }
  }
  for (size_t c = 0; c < pr->cells; ++c) { /* ½(B + Bᵀ) */
    double *B = out + c * P * P;
    for (size_t a = 0; a < P; ++a) {
      for (size_t b = a + 1; b < P; ++b) B[a * P + b] = B[b * P + a] = 0.5 * (B[a * P + b] + B[b * P + a]);
    }
  }
  return r;
}

HETINV_API hetinv_result_t hetinv_estimator_fisher_blocks(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t spacing,
    int32_t replicates, double *blocks, double *blocks_std_errors, size_t k) {
  HV_API_ENTER();
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, count, &pass);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = pass.ctx;
  double *w = NULL;
  if (blocks == NULL) r = HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'blocks' is NULL");
  if (r == HETINV_SUCCESS && (spacing < 1 || spacing > MAX_SPACING)) {
    r = HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "spacing is %d; expected an integer from 1 to %d",
                (int)spacing, MAX_SPACING);
  }
  if (r == HETINV_SUCCESS) {
    r = hv_fisher_check(&pass, medium, set, variances, map, replicates, "replicates", k, false, &w);
  }
  probes_t pr = {0};
  if (r == HETINV_SUCCESS) r = probes_make(ctx, map, k, spacing, &pr);
  const size_t V = (size_t)pass.grid.n[0] * (size_t)pass.grid.n[1] * (size_t)pass.grid.n[2];
  const size_t nb = pr.cells * pr.P * pr.P;
  double *Z = NULL, *tangent = NULL, *Y = NULL, *cot = NULL, *g = NULL, *one = NULL, *sum = NULL, *sq = NULL;
  if (r == HETINV_SUCCESS) {
    size_t nz = 0, nt = 0, ny = 0;
    if (!hv_mul_size((size_t)pr.T, k, &nz) || !hv_mul_size(3 * V, (size_t)pr.T, &nt) ||
        !hv_mul_size(count, (size_t)pr.T, &ny)) {
      r = HV_FAIL(ctx, HETINV_ERROR_SIZE_OVERFLOW, "%d probes of %zu entries overflow", (int)pr.T, k);
    } else {
      Z = hv_calloc(ctx, nz, sizeof(double));
      tangent = hv_calloc(ctx, nt, sizeof(double));
      Y = hv_calloc(ctx, ny, sizeof(double));
      cot = hv_calloc(ctx, count, sizeof(double));
      g = hv_calloc(ctx, k, sizeof(double));
      one = hv_calloc(ctx, nb, sizeof(double));
      sum = hv_calloc(ctx, nb, sizeof(double));
      sq = hv_calloc(ctx, nb, sizeof(double));
      if (!(Z && tangent && Y && cot && g && one && sum && sq)) {
        r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %d probes of %zu entries", (int)pr.T, k);
      }
    }
  }
  for (int32_t rep = 0; r == HETINV_SUCCESS && rep < replicates; ++rep) {
    r = replicate(&pass, map, w, count, &pr, rep, Z, tangent, Y, cot, g, one);
    for (size_t i = 0; r == HETINV_SUCCESS && i < nb; ++i) {
      sum[i] += one[i];
      sq[i] += one[i] * one[i];
    }
  }
  if (r == HETINV_SUCCESS) hv_fisher_mean_se(sum, sq, nb, replicates, blocks, blocks_std_errors);
  hv_free(ctx, pr.class_of);
  hv_free(ctx, w);
  hv_free(ctx, Z);
  hv_free(ctx, tangent);
  hv_free(ctx, Y);
  hv_free(ctx, cot);
  hv_free(ctx, g);
  hv_free(ctx, one);
  hv_free(ctx, sum);
  hv_free(ctx, sq);
  hv_pass_end(&pass);
  return r;
}
