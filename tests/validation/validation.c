#include "validation.h"

#include <math.h>
#include <stdlib.h>

double val_z_max(int comparisons) {
  /* Solve erfc(z / sqrt 2) = alpha / n by bisection: erfc is decreasing. */
  double p = VAL_FAMILY_ALPHA / (comparisons > 0 ? comparisons : 1);
  double lo = 0.0, hi = 40.0;
  for (int i = 0; i < 200; ++i) {
    double mid = 0.5 * (lo + hi);
    if (erfc(mid / sqrt(2.0)) > p) lo = mid; else hi = mid;
  }
  return 0.5 * (lo + hi);
}

/* Continued fraction of the regularised incomplete beta function
 * (Lentz's method, as in Numerical Recipes' betacf). */
static double beta_cf(double a, double b, double x) {
  const double tiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (fabs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 10000; ++m) {
    double m2 = 2.0 * m;
    double num = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
    d = 1.0 + num * d;
    c = 1.0 + num / c;
    if (fabs(d) < tiny) d = tiny;
    if (fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    h *= d * c;
    num = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
    d = 1.0 + num * d;
    c = 1.0 + num / c;
    if (fabs(d) < tiny) d = tiny;
    if (fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    double delta = d * c;
    h *= delta;
    if (fabs(delta - 1.0) < 1e-15) break;
  }
  return h;
}

/* Regularised incomplete beta I_x(a, b). */
double val_beta_inc(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  double front = exp(lgamma(a + b) - lgamma(a) - lgamma(b) + a * log(x) + b * log1p(-x));
  if (x < (a + 1.0) / (a + b + 2.0)) return front * beta_cf(a, b, x) / a;
  return 1.0 - front * beta_cf(b, a, 1.0 - x) / b;
}

double val_t_max(int dof, int comparisons) {
  /* P(|T| > t) = I_{ν/(ν+t²)}(ν/2, 1/2), decreasing in t. */
  double p = VAL_FAMILY_ALPHA / (comparisons > 0 ? comparisons : 1), nu = dof;
  double lo = 0.0, hi = 1000.0;
  for (int i = 0; i < 200; ++i) {
    double mid = 0.5 * (lo + hi);
    if (val_beta_inc(0.5 * nu, 0.5, nu / (nu + mid * mid)) > p) lo = mid; else hi = mid;
  }
  return 0.5 * (lo + hi);
}

uint64_t val_seed(uint64_t fixed) {
  const char *s = getenv("HETINV_VALIDATION_SEED");
  return s != NULL && *s != '\0' ? (uint64_t)strtoull(s, NULL, 0) : fixed;
}

double val_photons(double full) {
  double n = floor(full * (double)HETINV_VALIDATION_SCALE + 0.5);
  double least = 32.0;
  return n < least ? least : n;
}

hetinv_context_t *val_context(uint64_t seed, int32_t threads) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.seed = seed;
  init.thread_count = threads;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  return ctx;
}

hetinv_estimator_t *val_estimator(hetinv_context_t *ctx, double full_photons) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(ctx, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, val_photons(full_photons)));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, VAL_BATCHES));
  return est;
}

hetinv_medium_t *val_medium(hetinv_context_t *ctx, const double lo[3], const double hi[3],
                            const int32_t dims[3], double sigma_a, double sigma_s, double g,
                            double eta, double eta_out, int commit) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, lo, hi, dims, &m));
  assert_ok(hetinv_medium_fill(m, sigma_a, sigma_s, g));
  assert_ok(hetinv_medium_set_ior(m, eta, eta_out));
  if (commit) assert_ok(hetinv_medium_commit(m));
  return m;
}

int val_compare(const char *case_id, const char *quantity, double ref, double ref_se, double est,
                double se, double z_max, uint64_t seed) {
  double sigma = sqrt(se * se + ref_se * ref_se);
  double z = sigma > 0.0 ? (est - ref) / sigma : (est == ref ? 0.0 : HUGE_VAL);
  int pass = fabs(z) <= z_max;
  printf("VALIDATION %s %s ref=%.7g ref_se=%.2g est=%.7g se=%.3g z=%+.2f zmax=%.2f seed=%llu %s\n",
         case_id, quantity, ref, ref_se, est, se, z, z_max, (unsigned long long)seed,
         pass ? "PASS" : "FAIL");
  fflush(stdout);
  return pass;
}

int val_check_exact(const char *case_id, const char *quantity, double ref, double est, double tol,
                    uint64_t seed) {
  int pass = fabs(est - ref) <= tol;
  printf("VALIDATION %s %s ref=%.17g est=%.17g diff=%.3g tol=%.3g seed=%llu %s\n", case_id,
         quantity, ref, est, est - ref, tol, (unsigned long long)seed, pass ? "PASS" : "FAIL");
  fflush(stdout);
  return pass;
}

void val_note(const char *case_id, const char *quantity, double value, double se) {
  printf("VALIDATION %s %s value=%.7g se=%.3g NOTE\n", case_id, quantity, value, se);
  fflush(stdout);
}

uint64_t val_splitmix64(uint64_t *state) {
  uint64_t z = (*state += UINT64_C(0x9e3779b97f4a7c15));
  z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
  z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
  return z ^ (z >> 31);
}

double val_uniform(uint64_t *state) { return (double)(val_splitmix64(state) >> 11) * 0x1p-53; }

hetinv_medium_t *val_heterogeneous(hetinv_context_t *ctx, const double lo[3], const double hi[3],
                                   const int32_t dims[3], const val_ranges_t *ranges,
                                   uint64_t pattern, double eta, double eta_out) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, lo, hi, dims, &m));
  assert_ok(hetinv_medium_set_ior(m, eta, eta_out));
  uint64_t state = pattern;
  for (int32_t iz = 0; iz < dims[2]; ++iz) {
    for (int32_t iy = 0; iy < dims[1]; ++iy) {
      for (int32_t ix = 0; ix < dims[0]; ++ix) {
        double u[3] = {val_uniform(&state), val_uniform(&state), val_uniform(&state)};
        double sa = ranges->sigma_a[0] + u[0] * (ranges->sigma_a[1] - ranges->sigma_a[0]);
        double ss = ranges->sigma_s[0] + u[1] * (ranges->sigma_s[1] - ranges->sigma_s[0]);
        double g = ranges->g[0] + u[2] * (ranges->g[1] - ranges->g[0]);
        assert_ok(hetinv_medium_set_voxel(m, ix, iy, iz, sa, ss, g));
      }
    }
  }
  return m;
}
