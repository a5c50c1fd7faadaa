/* A measurement, not a test (built, not registered in CTest; figures and
 * commands in docs/results/gain.md): the bias of the loss gradient with a
 * global calibration gain (hetinv_estimator_set_gain_mode,
 * HETINV_GAIN_GLOBAL) against the gradient of the reduced loss of the
 * expected render,
 *   L̄*(π) = min_k Σ_n m_n w_n (k·E[I_n](π) − Ī_n)²,
 * whose gradient is (envelope theorem) Σ_n 2 m_n w_n k̄ (k̄ E[I_n] − Ī_n)
 * ∂E[I_n]/∂π with k̄ = Σ m w E[I] Ī / Σ m w E[I]². The library fits k from
 * the render of stream s, so its gradient carries a bias of order
 * 1/photons (hetinv/estimator.h). Problem, calls and reference streams are
 * those of test_gradient_loss.c; N photons per call from the environment
 * variable HETINV_GAIN_CALL_PHOTONS (default 200). The reference's error:
 * per stream j, the spread of Σ coef D_j (D varies) and of Σ coef(C_j) D̄
 * (C varies, k̄ refitted per stream). It prints one VALIDATION line per π
 * entry (z, and PASS/FAIL against the Bonferroni bound) and exits 0: a FAIL
 * line is the bias seen, which is what it measures. */
#include <math.h>
#include <stdlib.h>

#include "loss_problem.h"
#include "test_gradient_common.h"

#define COMPARISONS 6
#define K LOSS_K
#define VALUES LOSS_VALUES
#define CALLS 3000       /* R loss-gradient calls (epochs 1..R), times the scale */
#define CALL_PHOTONS 200 /* N photons per call by default: small on purpose, not scaled */
#define STREAMS LOSS_STREAMS

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0c01)

typedef loss_problem_t problem_t;
static const double *const weight = loss_weight;
static const uint8_t *const mask = loss_mask;

/* 2 m w k (k C − Ī) with k the least-squares gain of C. */
static void gain_coef(const double C[VALUES], const double measured[VALUES], double coef[VALUES]) {
  double num = 0.0, den = 0.0;
  for (int n = 0; n < VALUES; ++n) {
    if (!mask[n]) continue;
    num += weight[n] * C[n] * measured[n];
    den += weight[n] * C[n] * C[n];
  }
  double k = num / den;
    for (int n = 0; n < VALUES; ++n) coef[n] = mask[n] ? 2.0 * weight[n] * k * (k * C[n] - measured[n]) : 0.0;
}

static void gain_gradient_mean_is_gradient_of_reduced_loss_of_mean(void **state) {
  (void)state;
  problem_t p;
  loss_problem_build(&p, seed);
  double measured[VALUES];
  loss_problem_set_measured(&p, measured);
  double t0 = grad_now();

  /* The estimator: R calls of N photons, epochs 1..R. */
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(p.ctx, &est));
  const char *env = getenv("HETINV_GAIN_CALL_PHOTONS");
  double call_photons = env ? atof(env) : CALL_PHOTONS;
  assert_true(call_photons >= 1.0);
  int calls = (int)floor(CALLS * (double)HETINV_VALIDATION_SCALE + 0.5);
  if (calls < 500) calls = 500; /* the mean of few-photon calls needs many of them */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, call_photons));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2));
  double *samples = calloc((size_t)calls * K, sizeof *samples);
  assert_non_null(samples);
  for (int r = 0; r < calls; ++r) {
    double grad[K];
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, r + 1.0));
    if (r == 0) assert_ok(hetinv_estimator_set_gain_mode(est, HETINV_GAIN_GLOBAL));
    assert_ok(hetinv_estimator_loss_gradient(est, p.medium, p.set, p.map, NULL, NULL, grad, K));
    for (int k = 0; k < K; ++k) samples[(size_t)k * calls + r] = grad[k];
  }
  hetinv_estimator_destroy(&est);
  double t1 = grad_now();

  /* The reference's two factors (loss_problem_reference). */
  static double D[STREAMS][VALUES][K], C[STREAMS][VALUES];
  double per_stream = loss_problem_reference(&p, D, C);
  double t2 = grad_now();
  printf("loss gradient: %d calls of %.0f photons in %.1f s; reference: %d streams x %d renders "
         "of %.0f photons in %.1f s\n",
         calls, call_photons, t1 - t0, STREAMS, 2 * K + 1, per_stream, t2 - t1);

  /* Means of both factors, the reference and its delta-method error. */
  double Dbar[VALUES][K] = {{0}}, Cbar[VALUES] = {0};
  for (int j = 0; j < STREAMS; ++j) {
    for (int n = 0; n < VALUES; ++n) {
      Cbar[n] += C[j][n] / STREAMS;
      for (int k = 0; k < K; ++k) Dbar[n][k] += D[j][n][k] / STREAMS;
    }
  }
  double coef[VALUES]; /* 2 m w k̄ (k̄ Ī(π) − Ī) */
  gain_coef(Cbar, measured, coef);
  for (int n = 0; n < VALUES; ++n) {
    printf("value %d: I(pi) = %.6g, measured %.6g, weight %g, mask %d\n", n, Cbar[n], measured[n],
           weight[n], mask[n]);
  }
  int failures = 0;
  for (int k = 0; k < K; ++k) {
    double ref = 0.0, a[STREAMS], b[STREAMS], ma, sa, mb, sb;
    for (int n = 0; n < VALUES; ++n) ref += coef[n] * Dbar[n][k];
    for (int j = 0; j < STREAMS; ++j) {
      a[j] = b[j] = 0.0;
      for (int n = 0; n < VALUES; ++n) {
        a[j] += coef[n] * D[j][n][k];                                                /* D varies */
      }
      double cj[VALUES];
      gain_coef(C[j], measured, cj);
      for (int n = 0; n < VALUES; ++n) b[j] += cj[n] * Dbar[n][k];                /* C varies */
    }
    grad_mean_se(a, STREAMS, &ma, &sa);
    grad_mean_se(b, STREAMS, &mb, &sb);
    double ref_se = sqrt(sa * sa + sb * sb);
    double ref_dof = grad_welch_dof(sa, STREAMS - 1.0, sb, STREAMS - 1.0);
    double mean, se;
    grad_mean_se(samples + (size_t)k * calls, calls, &mean, &se);
    hetinv_param_t param;
    size_t cell;
    assert_ok(hetinv_param_map_entry(p.map, (size_t)k, &param, &cell));
    char name[64];
    snprintf(name, sizeof name, "gain/E[grad]/%s/voxel%zu", hetinv_param_name(param), cell);
    failures += !grad_compare(name, ref, ref_se, ref_dof, mean, se, calls - 1.0, COMPARISONS, seed);
  }
  free(samples);
  loss_problem_destroy(&p);
  printf("%d of %d comparisons beyond the bound (the gain's bias at %.0f photons per call)\n",
         failures, K, call_photons);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(gain_gradient_mean_is_gradient_of_reduced_loss_of_mean),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
