/* Score-function gradients of once-scattered radiance against the
 * derivatives of the closed forms of an index-matched homogeneous slab
 * (Prahl 1988, thesis §3, Eqs. 3.30–3.32; tests/validation/transport-cases.md), with
 * HETINV_ESTIMATOR_MIN_SCATTERING = MAX_SCATTERING = 1:
 *   L_R(μ)  = a E p(Θ) F_R(τ),  F_R = μ0/(μ+μ0) [1 − e^{−τ(1/μ + 1/μ0)}]
 *   L_T(μ)  = a E p(Θ) F_T(τ),  F_T = μ0/(μ0−μ) [e^{−τ/μ0} − e^{−τ/μ}]   (μ ≠ μ0)
 *   L_T(μ0) = a E p(Θ) F_T(τ),  F_T = (τ/μ0) e^{−τ/μ0}
 * with a = σs/σt, τ = σt·d, σt = σa + σs, p the Henyey–Greenstein phase
 * function at the scattering angle Θ between beam and exit direction.
 *
 * Derivatives (the slab is one voxel, so ∂/∂(voxel parameter) is the
 * derivative with respect to the slab's parameter):
 *   ∂a/∂σa = −σs/σt²,  ∂a/∂σs = σa/σt²,  ∂τ/∂σa = ∂τ/∂σs = d;
 *   ∂L/∂σ  = E p [ (∂a/∂σ) F + a d F'(τ) ],  σ ∈ {σa, σs};
 *   F_R'   = μ0/(μ+μ0) k e^{−τk},  k = 1/μ + 1/μ0;
 *   F_T'   = μ0/(μ0−μ) [e^{−τ/μ}/μ − e^{−τ/μ0}/μ0]          (μ ≠ μ0);
 *   F_T'   = e^{−τ/μ0} (1 − τ/μ0) / μ0                         (μ = μ0);
 *   ∂L/∂g  = L ∂log p/∂g,  ∂log p/∂g = −2g/(1−g²) − 3(g − cosΘ)/(1 + g² − 2g cosΘ).
 * The algebra is checked in the test itself against central differences
 * of the closed forms (deterministic, 1e-6 relative).
 *
 * Geometry and units as in test_single_scattering.c: a box of thickness
 * d = 0.5 mm and 200·d wide (one voxel, grid 1 × 1 × 1), a collimated area
 * source over [−5, 5]² of the top face, one orthographic pixel [−3, 3]²
 * per exit direction. The area source spreads power 1 over the lit area A,
 * so the flux density across the face is 1/A and E = 1/(A μ0); the
 * orthographic value is the outgoing radiance averaged over the pixel per
 * unit emitted power. Every once-scattered path ending in the pixel starts
 * inside the lit rectangle (margin 2 mm > d(tanθ + tanθ0) ≤ 1.24 mm), for
 * every value of the parameters, so the closed form and its derivatives
 * hold exactly for the pixel average.
 *
 * The gradient of each pixel is one call with a one-hot cotangent; its
 * standard error comes from 256 batch means (Student-t, 255 dof). 8 exit
 * directions (normal and oblique incidence) × 3 parameters = 24
 * comparisons, Bonferroni threshold at VAL_FAMILY_ALPHA / 24. */
#include <math.h>

#include "test_gradient_common.h"

#define COMPARISONS 24
#define PHOTONS 4e6 /* per gradient call */

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0b01)

static const double slab_d = 0.5;                              /* mm */
static const double sig_a = 0.25, sig_s = 0.9, hg_g = 0.4;     /* τ = 0.575, a = 0.783 */
static const double lit = 5.0;                                 /* lit rectangle [-lit, lit]² */
static const double pix = 3.0;                                 /* pixel [-pix, pix]² */

typedef struct slab {
  double sa, ss, g;
} slab_t;

typedef struct closed_form {
  double L, d_sa, d_ss, d_g;
} closed_form_t;

static double hg(double g, double c) {
  double q = 1.0 + g * g - 2.0 * g * c;
  return (1.0 - g * g) / (4.0 * VAL_PI * q * sqrt(q));
}

/* The closed form and its three derivatives, beam travelling along `beam`
 * with irradiance E (normal to the beam), light leaving along `out`. */
static closed_form_t prahl(slab_t s, const double beam[3], const double out[3], double E) {
  double st = s.sa + s.ss, tau = st * slab_d, a = s.ss / st;
  double da_dsa = -s.ss / (st * st), da_dss = s.sa / (st * st);
  double mu0 = -beam[2], mu = fabs(out[2]);
  double c = beam[0] * out[0] + beam[1] * out[1] + beam[2] * out[2];
  double p = hg(s.g, c);
  double dlogp = -2.0 * s.g / (1.0 - s.g * s.g) - 3.0 * (s.g - c) / (1.0 + s.g * s.g - 2.0 * s.g * c);
  double F, dF;
  if (out[2] > 0.0) {
    double k = 1.0 / mu + 1.0 / mu0;
    F = mu0 / (mu + mu0) * (1.0 - exp(-tau * k));
    dF = mu0 / (mu + mu0) * k * exp(-tau * k);
  } else if (fabs(mu - mu0) < 1e-12) {
    F = tau / mu0 * exp(-tau / mu0);
    dF = exp(-tau / mu0) * (1.0 - tau / mu0) / mu0;
  } else {
    F = mu0 / (mu0 - mu) * (exp(-tau / mu0) - exp(-tau / mu));
    dF = mu0 / (mu0 - mu) * (exp(-tau / mu) / mu - exp(-tau / mu0) / mu0);
  }
  closed_form_t r;
  r.L = a * E * p * F;
  r.d_sa = E * p * (da_dsa * F + a * slab_d * dF);
  r.d_ss = E * p * (da_dss * F + a * slab_d * dF);
  r.d_g = r.L * dlogp;
  return r;
}

/* The derivatives above against central differences of L itself. */
static void check_algebra(const double beam[3], const double out[3], double E) {
  const slab_t s = {sig_a, sig_s, hg_g};
  closed_form_t r = prahl(s, beam, out, E);
  const double eps = 1e-6;
  double fd[3];
  for (int p = 0; p < 3; ++p) {
    slab_t up = s, down = s;
    double *u = p == 0 ? &up.sa : (p == 1 ? &up.ss : &up.g);
    double *w = p == 0 ? &down.sa : (p == 1 ? &down.ss : &down.g);
    *u += eps;
    *w -= eps;
    fd[p] = (prahl(up, beam, out, E).L - prahl(down, beam, out, E).L) / (2.0 * eps);
  }
  double an[3] = {r.d_sa, r.d_ss, r.d_g};
  for (int p = 0; p < 3; ++p) {
    if (!(fabs(an[p] - fd[p]) <= 1e-6 * (fabs(r.L) + fabs(an[p])))) {
      print_error("closed-form derivative %d: analytic %.10g, numerical %.10g\n", p, an[p], fd[p]);
      fail();
    }
  }
}

typedef struct direction_case {
  const char *name;
  double out[3];
} direction_case_t;

static int compare_directions(const char *case_id, const double beam[3],
                              const direction_case_t *dirs, int n) {
  hetinv_context_t *ctx = val_context(seed, 1);
  double half = 100.0 * slab_d;
  hetinv_medium_t *m = val_medium(ctx, (double[]){-half, -half, 0.0}, (double[]){half, half, slab_d},
                                  (int32_t[]){1, 1, 1}, sig_a, sig_s, hg_g, 1.0, 1.0, 1);
  hetinv_emitter_t *source = NULL;
  assert_ok(hetinv_emitter_create_area(m, HETINV_FACE_Z_MAX, beam, (double[]){-lit, -lit},
                                       (double[]){lit, lit}, 1, 1, NULL, &source));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  hetinv_sensor_t *sensors[4] = {NULL};
  assert_true(n <= 4);
  for (int i = 0; i < n; ++i) {
    hetinv_face_t face = dirs[i].out[2] > 0.0 ? HETINV_FACE_Z_MAX : HETINV_FACE_Z_MIN;
    assert_ok(hetinv_sensor_create_orthographic(m, face, dirs[i].out, (double[]){-pix, -pix},
                                                (double[]){2 * pix, 2 * pix}, 1, 1, &sensors[i]));
    assert_ok(hetinv_measurements_add(set, source, sensors[i], steady, NULL));
  }
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, HETINV_FREE_ALL, &map));
  hetinv_estimator_t *est = val_estimator(ctx, PHOTONS);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, 1));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 1));

  double mu0 = -beam[2];
  double E = 1.0 / ((2 * lit) * (2 * lit) * mu0); /* see the file comment */
  const slab_t s = {sig_a, sig_s, hg_g};
  int failures = 0;
  double t0 = grad_now();
  for (int i = 0; i < n; ++i) {
    double cot[4] = {0};
    cot[i] = 1.0;
    double grad[3], grad_se[3];
    assert_ok(hetinv_estimator_gradient(est, m, set, cot, (size_t)n, map, grad, grad_se, 3));
    check_algebra(beam, dirs[i].out, E);
    closed_form_t ref = prahl(s, beam, dirs[i].out, E);
    double refs[3] = {ref.d_sa, ref.d_ss, ref.d_g};
    for (hetinv_param_t p = 0; p < 3; ++p) {
      char name[96];
      snprintf(name, sizeof name, "%s/%s_mu%.2f_%s/d%s", case_id, dirs[i].out[2] > 0 ? "L_R" : "L_T",
               fabs(dirs[i].out[2]), dirs[i].name, hetinv_param_name(p));
      failures += !grad_compare(name, refs[p], 0.0, (double)INFINITY, grad[p], grad_se[p], GRAD_BATCH_DOF,
                                COMPARISONS, seed);
    }
  }
  double photons;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_PHOTONS, &photons));
  printf("%s: %d gradient calls of %.0f photons in %.1f s\n", case_id, n, photons, grad_now() - t0);
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  hetinv_measurements_destroy(&set);
  for (int i = 0; i < n; ++i) hetinv_sensor_destroy(&sensors[i]);
  hetinv_pathlength_destroy(&steady);
  hetinv_emitter_destroy(&source);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return failures;
}

static const double s08 = 0.6, s05 = 0.86602540378443864676; /* sinθ at μ = 0.8, 0.5 */

static void normal_incidence_derivatives(void **state) {
  (void)state;
  const double beam[3] = {0.0, 0.0, -1.0};
  const direction_case_t dirs[] = {
      {"normal", {0.0, 0.0, 1.0}},  /* Θ = 180° */
      {"phi0", {s05, 0.0, 0.5}},
      {"normal", {0.0, 0.0, -1.0}}, /* μ = μ0, Θ = 0 */
      {"phi90", {0.0, s08, -0.8}},
  };
  val_assert_all_passed(compare_directions("SS_mu0_1.00", beam, dirs, 4));
}

/* μ0 = 0.8: the beam travels along (0.6, 0, -0.8). */
static void oblique_incidence_derivatives(void **state) {
  (void)state;
  const double beam[3] = {s08, 0.0, -0.8};
  const direction_case_t dirs[] = {
      {"backscatter", {-s08, 0.0, 0.8}}, /* Θ = 180° */
      {"phi90", {0.0, s05, 0.5}},
      {"forward", {s08, 0.0, -0.8}},     /* μ = μ0, Θ = 0 */
      {"normal", {0.0, 0.0, -1.0}},
  };
  val_assert_all_passed(compare_directions("SS_mu0_0.80", beam, dirs, 4));
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(normal_incidence_derivatives),
      cmocka_unit_test(oblique_incidence_derivatives),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
