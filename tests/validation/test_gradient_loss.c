/* The stochastic gradient of the appearance-matching loss
 * (hetinv_estimator_loss_gradient, Eqs. 9, 21–22) is unbiased for the
 * gradient of the loss of the expected render.
 *
 * What the expectation is. With measured values Ī_n, weights w_n and mask
 * m_n, the library renders I_n with stream s, forms the cotangent
 * c_n = 2 m_n w_n (I_n − Ī_n) and estimates Σ_n c_n ∂I_n/∂π by G_n(π), the
 * score-function estimate from the independent stream s + 1. Since I and
 * G are independent and E[G_n] = ∂E[I_n]/∂π,
 *   E[grad] = Σ_n 2 m_n w_n (E[I_n] − Ī_n) ∂E[I_n]/∂π = ∇ L̄(π),
 *   L̄(π)   = Σ_n m_n w_n (E[I_n](π) − Ī_n)²,
 * the loss of the expected render. It is not the gradient of the expected
 * loss E[L] = L̄ + Σ_n m_n w_n Var(I_n), whose extra term has gradient
 * Σ m w ∂Var(I_n)/∂π ≠ 0; nor would it be unbiased if I and G shared their
 * paths (E[I G] = E[I] E[G] + Cov(I, G), a bias of order 1/photons). To
 * make the test sensitive to such a bias, each call uses few photons
 * (N = 200) and the mean is taken over many calls (R = 3000 epochs, each
 * with a fresh seed through HETINV_ESTIMATOR_EPOCH); its standard error
 * comes from the spread of the R gradients. (An implementation that takes
 * I and G from the same stream was measured on this problem at
 * z ≈ −9 for ∂/∂σa and ∂/∂σs of voxel 0: the test sees that bias.)
 *
 * Reference. ∇L̄ = Σ_n 2 m_n w_n (Ī_n(π) − Ī_n) D_n with D_n the central
 * finite difference (h = 10 % of σ, 0.05 for g) of the expected values,
 * estimated with common random numbers over M = 64 independent streams,
 * and Ī_n(π) from M further independent streams (so that the two factors
 * are independent and their product unbiased). Its standard error is the
 * delta-method combination of the spreads over the streams of both
 * factors (63 dof). The O(h²) truncation of D is below it: during
 * development, halving h (with 4× the photons, the same streams) moved the
 * six references by at most 0.4 of their standard errors in this test.
 *
 * Problem. 2 × 1 × 1 voxels of 1 mm (box [0, 2] × [0, 1] × [0, 1]),
 * η = 1.3 in air, a pencil beam into the top of voxel 0 tilted toward
 * voxel 1; hemispherical detectors on the top, bottom and x = 2 faces with
 * weights 1, 2, 0.5, and an orthographic pixel whose value is masked out
 * (it must not contribute at all). π: σa, σs, g of both voxels (K = 6).
 * The measured values are the values of this medium scaled by 0.6, 1.4
 * and 0.8 (any fixed values would do; these give residuals of either sign).
 * 6 comparisons, Bonferroni with the Student-t quantile of the
 * Welch–Satterthwaite dof.
 *
 * Besides, exact checks of the structure: the loss and rendered values
 * are those of hetinv_estimator_render with stream s, and the gradient is,
 * bit for bit, hetinv_estimator_gradient with stream s + 1 (wrapping at
 * 65536) and the cotangent 2·m·w·(I − Ī). */
#include <math.h>
#include <stdlib.h>

#include "loss_problem.h"
#include "test_gradient_common.h"

#define COMPARISONS 6
#define K LOSS_K
#define VALUES LOSS_VALUES
#define CALLS 3000       /* R loss-gradient calls (epochs 1..R), times the scale */
#define CALL_PHOTONS 200 /* N photons per call: small on purpose, not scaled */
#define STREAMS LOSS_STREAMS

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0c01)

typedef loss_problem_t problem_t;
static const double *const weight = loss_weight;
static const uint8_t *const mask = loss_mask;

/* The library's cotangent 2·m·w·(I − Ī), in its own order of operations. */
static void cotangent_of(const double rendered[VALUES], const double measured[VALUES], double cot[VALUES]) {
  for (int n = 0; n < VALUES; ++n) cot[n] = 2.0 * (mask[n] ? weight[n] * (rendered[n] - measured[n]) : 0.0);
}

/* Exact structure of one call, at stream s. */
static int check_structure(problem_t *p, const double measured[VALUES], double stream) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(p->ctx, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 3000));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, 7));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, stream));
  double loss, rendered[VALUES], grad[K];
  assert_ok(hetinv_estimator_loss_gradient(est, p->medium, p->set, p->map, &loss, rendered, grad, K));
  double again[VALUES], grad_direct[K], cot[VALUES];
  assert_ok(hetinv_estimator_render(est, p->medium, p->set, again, NULL, NULL, VALUES));
  int failures = 0;
  char what[64];
  for (int n = 0; n < VALUES; ++n) {
    snprintf(what, sizeof what, "loss/stream%.0f/rendered[%d]_is_render", stream, n);
    failures += !val_check_exact("GRAD", what, again[n], rendered[n], 0.0, seed);
  }
  double expect = 0.0;
  for (int n = 0; n < VALUES; ++n) {
    double r = rendered[n] - measured[n];
    expect += mask[n] ? weight[n] * r * r : 0.0;
  }
  snprintf(what, sizeof what, "loss/stream%.0f/loss_is_sum_m_w_r2", stream);
  failures += !val_check_exact("GRAD", what, expect, loss, 1e-13 * expect, seed);
  cotangent_of(rendered, measured, cot);
  double next = fmod(stream + 1.0, 65536.0);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, next));
  assert_ok(hetinv_estimator_gradient(est, p->medium, p->set, cot, VALUES, p->map, grad_direct, NULL, K));
  for (int k = 0; k < K; ++k) {
    snprintf(what, sizeof what, "loss/stream%.0f/grad[%d]_is_gradient_stream%.0f", stream, k, next);
    failures += !val_check_exact("GRAD", what, grad_direct[k], grad[k], 0.0, seed);
  }
  /* The gradient's paths are not the render's: with stream s the same
   * cotangent gives another estimate. */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, stream));
  double grad_same[K];
  assert_ok(hetinv_estimator_gradient(est, p->medium, p->set, cot, VALUES, p->map, grad_same, NULL, K));
  assert_memory_not_equal(grad_same, grad, sizeof grad);
  hetinv_estimator_destroy(&est);
  return failures;
}

static void loss_gradient_structure_is_exact(void **state) {
  (void)state;
  problem_t p;
  loss_problem_build(&p, seed);
  double measured[VALUES];
  loss_problem_set_measured(&p, measured);
  int failures = check_structure(&p, measured, 0) + check_structure(&p, measured, 123) +
                 check_structure(&p, measured, 65535); /* the gradient's stream wraps to 0 */
  loss_problem_destroy(&p);
  val_assert_all_passed(failures);
}

static void loss_gradient_mean_is_gradient_of_loss_of_mean(void **state) {
  (void)state;
  problem_t p;
  loss_problem_build(&p, seed);
  double measured[VALUES];
  loss_problem_set_measured(&p, measured);
  double t0 = grad_now();

  /* The estimator: R calls of N photons, epochs 1..R. */
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(p.ctx, &est));
  double call_photons = CALL_PHOTONS;
  int calls = (int)floor(CALLS * (double)HETINV_VALIDATION_SCALE + 0.5);
  if (calls < 500) calls = 500; /* the mean of few-photon calls needs many of them */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, call_photons));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2));
  double *samples = calloc((size_t)calls * K, sizeof *samples);
  assert_non_null(samples);
  for (int r = 0; r < calls; ++r) {
    double grad[K];
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_EPOCH, r + 1.0));
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
  double coef[VALUES]; /* 2 m w (Ī(π) − Ī) */
  for (int n = 0; n < VALUES; ++n) coef[n] = mask[n] ? 2.0 * weight[n] * (Cbar[n] - measured[n]) : 0.0;
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
        b[j] += mask[n] ? 2.0 * weight[n] * C[j][n] * Dbar[n][k] : 0.0;              /* C varies */
      }
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
    snprintf(name, sizeof name, "loss/E[grad]/%s/voxel%zu", hetinv_param_name(param), cell);
    failures += !grad_compare(name, ref, ref_se, ref_dof, mean, se, calls - 1.0, COMPARISONS, seed);
  }
  free(samples);
  loss_problem_destroy(&p);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(loss_gradient_structure_is_exact),
      cmocka_unit_test(loss_gradient_mean_is_gradient_of_loss_of_mean),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
