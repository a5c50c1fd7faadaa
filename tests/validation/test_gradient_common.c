#include "test_gradient_common.h"

#include <math.h>
#include <stdlib.h>
#include <time.h>

/* Two-sided Student-t tail P(|T| > t) for real-valued degrees of freedom. */
double grad_t_tail(double t, double dof) {
  if (!isfinite(dof) || dof > 1e7) return erfc(fabs(t) / sqrt(2.0));
  return val_beta_inc(0.5 * dof, 0.5, dof / (dof + t * t));
}

double grad_t_max(double dof, int comparisons) {
  double p = VAL_FAMILY_ALPHA / (comparisons > 0 ? comparisons : 1);
  double lo = 0.0, hi = 1e4; /* the tail decreases in t */
  for (int i = 0; i < 200; ++i) {
    double mid = 0.5 * (lo + hi);
    if (grad_t_tail(mid, dof) > p) lo = mid; else hi = mid;
  }
  return 0.5 * (lo + hi);
}

double grad_welch_dof(double se1, double dof1, double se2, double dof2) {
  double v1 = se1 * se1, v2 = se2 * se2;
  double den = (v1 > 0.0 ? v1 * v1 / dof1 : 0.0) + (v2 > 0.0 ? v2 * v2 / dof2 : 0.0);
  return den > 0.0 ? (v1 + v2) * (v1 + v2) / den : (double)INFINITY;
}

int grad_compare(const char *case_name, double ref, double ref_se, double ref_dof, double est,
                 double se, double est_dof, int comparisons, uint64_t seed) {
  double dof = grad_welch_dof(se, est_dof, ref_se, ref_dof);
  return val_compare("GRAD", case_name, ref, ref_se, est, se, grad_t_max(dof, comparisons), seed);
}

void grad_mean_se(const double *x, int n, double *mean, double *se) {
  double m = 0.0;
  for (int i = 0; i < n; ++i) m += x[i];
  m /= n;
  double ss = 0.0;
  for (int i = 0; i < n; ++i) ss += (x[i] - m) * (x[i] - m);
  *mean = m;
  *se = sqrt(ss / ((double)n - 1.0) / n);
}

double grad_uniform(uint64_t *state) {
  uint64_t z = (*state += UINT64_C(0x9e3779b97f4a7c15));
  z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
  z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
  z ^= z >> 31;
  return (double)(z >> 11) * 0x1.0p-53;
}

hetinv_medium_t *grad_perturbed(const hetinv_medium_t *base, const int32_t voxel[3],
                                hetinv_param_t param, double value) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_clone(base, &m));
  double v[3];
  assert_ok(hetinv_medium_get_voxel(base, voxel[0], voxel[1], voxel[2], &v[0], &v[1], &v[2]));
  v[param] = value;
  assert_ok(hetinv_medium_set_voxel(m, voxel[0], voxel[1], voxel[2], v[0], v[1], v[2]));
  assert_ok(hetinv_medium_commit(m));
  return m;
}

hetinv_estimator_t *grad_fd_estimator(hetinv_context_t *ctx, double photons_all_streams, int streams) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(ctx, &est));
  double per_stream = floor(photons_all_streams * (double)HETINV_VALIDATION_SCALE / streams + 0.5);
  if (per_stream < 64) per_stream = 64;
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, per_stream));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2));
  return est;
}

void grad_fd_voxel(hetinv_estimator_t *fd_est, const hetinv_medium_t *m, const hetinv_measurements_t *set,
                   const int32_t voxel[3], int values, int streams, double *mean, double *se,
                   double h[HETINV_PARAM_COUNT]) {
  double base[HETINV_PARAM_COUNT];
  assert_ok(hetinv_medium_get_voxel(m, voxel[0], voxel[1], voxel[2], &base[0], &base[1], &base[2]));
  /* d[n·streams + j]: value n's difference on stream j; ip, im: one render. */
  double *d = malloc((size_t)values * (size_t)streams * sizeof *d);
  double *ip = malloc((size_t)values * sizeof *ip), *im = malloc((size_t)values * sizeof *im);
  assert_non_null(d);
  assert_non_null(ip);
  assert_non_null(im);
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    h[p] = p == HETINV_PARAM_G ? 0.05 : 0.1 * base[p];
    hetinv_medium_t *plus = grad_perturbed(m, voxel, p, base[p] + h[p]);
    hetinv_medium_t *minus = grad_perturbed(m, voxel, p, base[p] - h[p]);
    for (int j = 0; j < streams; ++j) {
      assert_ok(hetinv_estimator_set_param(fd_est, HETINV_ESTIMATOR_STREAM, j));
      assert_ok(hetinv_estimator_render(fd_est, plus, set, ip, NULL, NULL, (size_t)values));
      assert_ok(hetinv_estimator_render(fd_est, minus, set, im, NULL, NULL, (size_t)values));
      for (int n = 0; n < values; ++n) d[(size_t)n * (size_t)streams + (size_t)j] = (ip[n] - im[n]) / (2.0 * h[p]);
    }
    for (int n = 0; n < values; ++n) {
      grad_mean_se(d + (size_t)n * (size_t)streams, streams, &mean[p * values + n], &se[p * values + n]);
    }
    hetinv_medium_destroy(&plus);
    hetinv_medium_destroy(&minus);
  }
  free(d);
  free(ip);
  free(im);
}

double grad_now(void) {
  struct timespec ts;
  if (timespec_get(&ts, TIME_UTC) != TIME_UTC) return 0.0;
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
