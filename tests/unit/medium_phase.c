/* Phase functions (lib/medium/phase.h): Henyey–Greenstein values, derivative,
 * sampling (χ² goodness of fit in the manner of Mitsuba 3's chi2.py) and the
 * direction frame. */
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "test_support.h"

#include "core/rng.h"
#include "medium/phase.h"

#define PI 3.14159265358979323846

static const double G_VALUES[] = {-0.9, -0.5, 0.0, 0.3, 0.75, 0.95};
enum { G_COUNT = sizeof G_VALUES / sizeof G_VALUES[0] };

/* Statistical tests draw from this seed; HETINV_TEST_SEED overrides it. */
static uint64_t test_seed(void) {
  const char *s = getenv("HETINV_TEST_SEED");
  return s != NULL ? strtoull(s, NULL, 0) : UINT64_C(0x13198a2e03707344);
}

/* ∫_a^b f(g, μ) μ^power dμ by composite Simpson with n (even) intervals. */
static double simpson(double (*f)(double, double), double g, int power, double a, double b,
                      int n) {
  double h = (b - a) / n, sum = 0.0, carry = 0.0; /* Kahan: n is up to 10^6 */
  for (int i = 0; i <= n; ++i) {
    double mu = a + i * h;
    double w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    double y = w * f(g, mu) * (power ? mu : 1.0) - carry, t = sum + y;
    carry = (t - sum) - y;
    sum = t;
  }
  return sum * h / 3.0;
}

static void assert_close(double actual, double expected, double tol, const char *what, double g) {
  if (!(fabs(actual - expected) <= tol)) {
    print_error("%s at g = %g: %.17g, expected %.17g (tolerance %g)\n", what, g, actual, expected,
                tol);
    fail();
  }
}

static void hg_integrates_to_one_over_the_sphere(void **state) {
  (void)state;
  for (int i = 0; i < G_COUNT; ++i) {
    double g = G_VALUES[i];
    assert_close(2.0 * PI * simpson(hv_hg_eval, g, 0, -1.0, 1.0, 1000000), 1.0, 1e-12, "∫f dω", g);
  }
}

static void hg_mean_cosine_is_g(void **state) {
  (void)state;
  for (int i = 0; i < G_COUNT; ++i) {
    double g = G_VALUES[i];
    assert_close(2.0 * PI * simpson(hv_hg_eval, g, 1, -1.0, 1.0, 1000000), g, 1e-12, "E[cosθ]", g);
  }
}

static void hg_cdf_integrates_the_pdf(void **state) {
  (void)state;
  for (int i = 0; i < G_COUNT; ++i) {
    double g = G_VALUES[i];
    double q = 0.0;
    for (double mu = -1.0; mu < 1.0; mu += 0.125) {
      q += 2.0 * PI * simpson(hv_hg_eval, g, 0, mu, mu + 0.125, 100000);
      assert_close(hv_hg_cdf(g, mu + 0.125), q, 1e-12, "CDF", g);
    }
    assert_true(hv_hg_cdf(g, -1.0) == 0.0);
  }
  assert_close(hv_hg_cdf(1e-300, 0.5), 0.75, 1e-15, "CDF", 1e-300); /* no 0/0 at g → 0 */
}

static void hg_dlog_dg_matches_finite_differences(void **state) {
  (void)state;
  const double h = 1e-5;
  for (int i = 0; i < G_COUNT; ++i) {
    double g = G_VALUES[i];
    for (double mu = -1.0; mu <= 1.0; mu += 0.0625) {
      double fd = (log(hv_hg_eval(g + h, mu)) - log(hv_hg_eval(g - h, mu))) / (2.0 * h);
      double d = hv_hg_dlog_dg(g, mu);
      assert_close(d, fd, 1e-6 * fmax(1.0, fabs(fd)), "d log f/dg", g);
    }
  }
  /* Near g = 0, f ≈ (1 + 3g cosθ)/(4π), so d log f/dg = 3 cosθ. */
  assert_close(hv_hg_dlog_dg(0.0, 0.4), 1.2, 1e-15, "d log f/dg", 0.0);
}

/* The CDF in extended precision, as the reference for sampling. */
static double hg_cdf_long(double g, double mu) {
  long double gl = (long double)g, ml = (long double)mu;
  long double s = sqrtl(1.0L + gl * gl - 2.0L * gl * ml);
  return (double)((1.0L - gl) * (1.0L + ml) / (s * (1.0L + gl + s)));
}

static void hg_sample_inverts_the_cdf(void **state) {
  (void)state;
  const double gs[] = {-0.999, -0.9, -0.3, -1e-7, 0.0, 1e-12, 1e-4, 0.5, 0.95, 0.999};
  for (size_t i = 0; i < sizeof gs / sizeof gs[0]; ++i) {
    double g = gs[i], prev = -2.0;
    for (int k = 0; k <= 1000; ++k) {
      double u = k / 1000.0, mu = hv_hg_sample_cos(g, u);
      assert_true(mu >= -1.0 && mu <= 1.0 && mu >= prev); /* in range, monotone */
      /* Rounding μ to a double alone moves the CDF by up to ε/2·2πf(μ), which
       * is 1e-10 at the peak of g = ±0.999: allow 2ε·(1 + 2πf) and no more
       * (the worst seen is 0.91 of that). */
      double tol = 2.0 * DBL_EPSILON * (1.0 + 2.0 * PI * hv_hg_eval(g, mu));
      assert_close(hg_cdf_long(g, mu), u, tol, "CDF(sample(u)) - u", g);
      prev = mu;
    }
  }
  /* Continuous through g = 0: no isotropic special case with an O(g) jump. */
  for (double u = 0.0; u <= 1.0; u += 0.1) {
    assert_close(hv_hg_sample_cos(1e-9, u), 2.0 * u - 1.0, 1e-8, "sample vs isotropic", 1e-9);
  }
}

static void generic_interface_dispatches_to_hg(void **state) {
  (void)state;
  hv_phase_t p = {HV_PHASE_HG, 0.6};
  assert_true(hv_phase_eval(p, 0.3) == hv_hg_eval(0.6, 0.3));
  assert_true(hv_phase_dlog_dg(p, 0.3) == hv_hg_dlog_dg(0.6, 0.3));
  assert_true(hv_phase_sample_cos(p, 0.7) == hv_hg_sample_cos(0.6, 0.7));
  double wi[3] = {0.0, 0.6, 0.8}, wo[3];
  double c = hv_phase_sample(p, wi, 0.7, 0.2, wo);
  assert_close(c, hv_hg_sample_cos(0.6, 0.7), 0.0, "returned cosθ", 0.6);
  assert_close(wo[0] * wi[0] + wo[1] * wi[1] + wo[2] * wi[2], c, 1e-15, "dot(wi, wo)", 0.6);
}

static double dot(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void random_direction(hv_rng_t *r, double w[3]) {
  double z = 2.0 * hv_rng_uniform(r) - 1.0, phi = 2.0 * PI * hv_rng_uniform(r);
  double s = sqrt(fmax(0.0, 1.0 - z * z));
  w[0] = s * cos(phi), w[1] = s * sin(phi), w[2] = z;
}

static void onb_is_orthonormal_and_right_handed_for_any_direction(void **state) {
  (void)state;
  const uint64_t seed = test_seed();
  hv_rng_t r = hv_rng_init(seed, 0, 0, 1);
  for (int k = 0; k < 10000; ++k) {
    double n[3], t[3], b[3];
    switch (k) { /* the poles and the equator, where frames usually break */
      case 0: n[0] = 0, n[1] = 0, n[2] = 1; break;
      case 1: n[0] = 0, n[1] = 0, n[2] = -1; break;
      case 2: n[0] = 1, n[1] = 0, n[2] = -0.0; break;
      case 3: n[0] = 0, n[1] = sqrt(1 - 1e-18), n[2] = -1e-9; break;
      case 4: n[0] = 1e-9, n[1] = 0, n[2] = -sqrt(1 - 1e-18); break;
      default: random_direction(&r, n);
    }
    hv_onb(n, t, b);
    double cross[3] = {t[1] * b[2] - t[2] * b[1], t[2] * b[0] - t[0] * b[2],
                       t[0] * b[1] - t[1] * b[0]};
    double err = fabs(dot(t, t) - 1) + fabs(dot(b, b) - 1) + fabs(dot(t, b)) + fabs(dot(t, n)) +
                 fabs(dot(b, n));
    for (int i = 0; i < 3; ++i) err += fabs(cross[i] - n[i]);
    if (!(err < 1e-14)) {
      print_error("seed %#llx, direction %d (%.17g, %.17g, %.17g): frame error %g\n",
                  (unsigned long long)seed, k, n[0], n[1], n[2], err);
      fail();
    }
  }
}

/* ---- χ² goodness of fit ----------------------------------------------------- */

/* Regularised upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a): the power series
 * of P = 1 - Q for x < a + 1, else the continued fraction of Q evaluated by
 * the modified Lentz method (Numerical Recipes §6.2). */
static double gamma_q(double a, double x) {
  if (x <= 0.0) return 1.0;
  double log_prefactor = a * log(x) - x - lgamma(a);
  if (x < a + 1.0) {
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 100000 && fabs(term) > 1e-17 * fabs(sum); ++n) {
      term *= x / (a + n);
      sum += term;
    }
    return 1.0 - sum * exp(log_prefactor);
  }
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    double delta = d * c;
    h *= delta;
    if (fabs(delta - 1.0) < 1e-16) break;
  }
  return exp(log_prefactor) * h;
}

/* Q(n, x) for integer n is the Poisson tail e^{-x} Σ_{k<n} x^k/k!. */
static double poisson_tail(int n, double x) {
  double sum = 0.0;
  for (int k = 0; k < n; ++k) sum += exp(k * log(x) - x - lgamma(k + 1.0));
  return sum;
}

static void incomplete_gamma_matches_closed_forms(void **state) {
  (void)state;
  static const struct { int n; double x; } cases[] = {
      {1, 0.1}, {1, 3.0}, {5, 2.0}, {5, 9.0}, {50, 45.0}, {50, 60.0}, {2500, 2450.0}, {2500, 2600.0},
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
    double q = gamma_q(cases[i].n, cases[i].x), ref = poisson_tail(cases[i].n, cases[i].x);
    assert_close(q, ref, 1e-12 + 1e-10 * ref, "Q(n, x)", cases[i].n);
  }
  for (double x = 0.05; x < 8.0; x *= 1.7) assert_close(gamma_q(0.5, x), erfc(sqrt(x)), 1e-13, "Q(1/2, x)", x);
}

enum { MU_BINS = 101, PHI_BINS = 50, CELLS = MU_BINS * PHI_BINS }; /* odd MU_BINS as chi2.py */

typedef struct { double expected, observed; } cell_t;

static int by_expected(const void *a, const void *b) {
  double x = ((const cell_t *)a)->expected, y = ((const cell_t *)b)->expected;
  return (x > y) - (x < y);
}

/* Pearson's statistic with cells of expected count < 5 pooled in increasing
 * order of expectation until each pool reaches 5 (chi2.py); a last pool still
 * under 5 joins the smallest regular cell. Returns the statistic and the
 * degrees of freedom (cells - 1). */
static double pearson(cell_t *cells, int n, int *dof) {
  qsort(cells, (size_t)n, sizeof *cells, by_expected);
  double stat = 0.0, pool_e = 0.0, pool_o = 0.0;
  int k = 0;
  for (int i = 0; i < n; ++i) {
    double e = cells[i].expected, o = cells[i].observed;
    if (e < 5.0) {
      pool_e += e, pool_o += o;
      if (pool_e < 5.0) continue;
      e = pool_e, o = pool_o;
      pool_e = pool_o = 0.0;
    } else if (pool_e > 0.0) {
      e += pool_e, o += pool_o;
      pool_e = pool_o = 0.0;
    }
    stat += (o - e) * (o - e) / e;
    ++k;
  }
  *dof = k - 1;
  return stat;
}

/* Samples n directions about wi with the given g through the full 3-D
 * construction and bins them by cosθ = dot(wi, wo) and by φ measured in a
 * frame built independently of hv_onb. Returns the χ² p-value. */
static double chi2_p_value(double g, const double wi[3], uint64_t seed, int n, double *stat_out,
                           int *dof_out) {
  static cell_t cells[CELLS];
  double helper[3] = {fabs(wi[0]) < 0.9 ? 1.0 : 0.0, fabs(wi[0]) < 0.9 ? 0.0 : 1.0, 0.0};
  double u[3] = {helper[1] * wi[2] - helper[2] * wi[1], helper[2] * wi[0] - helper[0] * wi[2],
                 helper[0] * wi[1] - helper[1] * wi[0]};
  double len = sqrt(dot(u, u));
  for (int i = 0; i < 3; ++i) u[i] /= len;
  double v[3] = {wi[1] * u[2] - wi[2] * u[1], wi[2] * u[0] - wi[0] * u[2],
                 wi[0] * u[1] - wi[1] * u[0]};
  for (int c = 0; c < CELLS; ++c) cells[c].observed = 0.0;
  hv_phase_t p = {HV_PHASE_HG, g};
  hv_rng_t r = hv_rng_init(seed, 0, 0, 2);
  for (int s = 0; s < n; ++s) {
    double wo[3];
    double u1 = hv_rng_uniform(&r), u2 = hv_rng_uniform(&r);
    hv_phase_sample(p, wi, u1, u2, wo);
    double mu = fmin(1.0, fmax(-1.0, dot(wi, wo)));
    double phi = atan2(dot(wo, v), dot(wo, u)) + PI;
    int im = (int)((mu + 1.0) * 0.5 * MU_BINS), ip = (int)(phi / (2.0 * PI) * PHI_BINS);
    im = im < MU_BINS ? im : MU_BINS - 1;
    ip = ip < PHI_BINS ? ip : PHI_BINS - 1;
    cells[im * PHI_BINS + ip].observed += 1.0;
  }
  /* Expected counts: the pdf integrated over each cell by Simpson's rule in
   * cosθ (independent of hv_hg_cdf) and exactly in φ. */
  double total = 0.0;
  for (int im = 0; im < MU_BINS; ++im) {
    double lo = -1.0 + 2.0 * im / MU_BINS, hi = -1.0 + 2.0 * (im + 1) / MU_BINS;
    double e = n * 2.0 * PI * simpson(hv_hg_eval, g, 0, lo, hi, 256) / PHI_BINS;
    for (int ip = 0; ip < PHI_BINS; ++ip) cells[im * PHI_BINS + ip].expected = e;
    total += e * PHI_BINS;
  }
  assert_close(total, n, 1e-6 * n, "expected counts", g);
  *stat_out = pearson(cells, CELLS, dof_out);
  return gamma_q(0.5 * *dof_out, 0.5 * *stat_out);
}

static void hg_sampling_passes_chi2_goodness_of_fit(void **state) {
  (void)state;
  const uint64_t seed = test_seed();
  const double alpha = 1.0 - pow(1.0 - 0.01, 1.0 / G_COUNT); /* Šidák over the g values */
  const double c = sqrt(1.0 / 3.0);
  /* A different incident direction per g, poles included, to test the frame too. */
  const double wi[G_COUNT][3] = {{0, 0, 1}, {0, 0, -1}, {c, -c, c}, {0.6, 0, -0.8},
                                 {-0.48, 0.6, 0.64}, {0, 1, 0}};
  bool ok = true;
  for (int i = 0; i < G_COUNT; ++i) {
    double stat;
    int dof;
    double pv = chi2_p_value(G_VALUES[i], wi[i], seed + (uint64_t)i, 1000000, &stat, &dof);
    print_message("g = %5.2f: chi2 = %9.2f, dof = %4d, p = %.4f (reject below %.5f)\n",
                  G_VALUES[i], stat, dof, pv, alpha);
    if (!(pv >= alpha)) {
      print_error("seed %#llx: HG sampling at g = %g rejected (p = %g)\n",
                  (unsigned long long)(seed + (uint64_t)i), G_VALUES[i], pv);
      ok = false;
    }
  }
  assert_true(ok);
}

/* hv_sincos_2pi against libm on every quadrant and its edges: the masks
 * that pick and negate the polynomials (core/bits.h) must give exactly
 * the branches' values, so each sign and each swap is checked. */
static void sincos_2pi_matches_libm_in_every_quadrant(void **state) {
  (void)state;
  double worst = 0.0;
  for (int i = 0; i <= 4096; ++i) {
    /* A grid with the quadrant edges and their neighbours, and the top of [0, 1). */
    double u = i < 4096 ? i / 4096.0 : 1.0 - 0x1p-32;
    for (int side = -1; side <= 1; ++side) {
      double v = side == 0 ? u : nextafter(u, side < 0 ? 0.0 : 1.0);
      if (!(v >= 0.0 && v < 1.0)) continue;
      double s, c;
      hv_sincos_2pi(v, &s, &c);
      double x = 2.0 * PI * v;
      double es = fabs(s - sin(x)), ec = fabs(c - cos(x));
      worst = fmax(worst, fmax(es, ec));
      /* Signs exactly, where the reference is not within rounding of 0. */
      if (fabs(sin(x)) > 1e-9) assert_true(signbit(s) == signbit(sin(x)));
      if (fabs(cos(x)) > 1e-9) assert_true(signbit(c) == signbit(cos(x)));
    }
  }
  print_message("largest |error| of sin, cos: %.3g\n", worst);
  /* 2π·u itself is rounded in the reference: a few ulps of 2π. */
  assert_true(worst < 4e-15);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(hg_integrates_to_one_over_the_sphere),
      cmocka_unit_test(hg_mean_cosine_is_g),
      cmocka_unit_test(hg_cdf_integrates_the_pdf),
      cmocka_unit_test(hg_dlog_dg_matches_finite_differences),
      cmocka_unit_test(hg_sample_inverts_the_cdf),
      cmocka_unit_test(generic_interface_dispatches_to_hg),
      cmocka_unit_test(onb_is_orthonormal_and_right_handed_for_any_direction),
      cmocka_unit_test(incomplete_gamma_matches_closed_forms),
      cmocka_unit_test(hg_sampling_passes_chi2_goodness_of_fit),
      cmocka_unit_test(sincos_2pi_matches_libm_in_every_quadrant),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
