/* Once-scattered radiance of an index-matched homogeneous slab against the
 * closed forms of Prahl (1988, thesis §3, Eqs. 3.30–3.32), quoted in
 * tests/validation/transport-cases.md:
 *   L_R(μ) = a E p(Θ) μ0/(μ+μ0) [1 − e^{−τ(1/μ + 1/μ0)}]
 *   L_T(μ) = a E p(Θ) μ0/(μ0−μ) [e^{−τ/μ0} − e^{−τ/μ}],  μ ≠ μ0
 *   L_T(μ0) = a E p(Θ) (τ/μ0) e^{−τ/μ0}
 * with HETINV_ESTIMATOR_MIN_SCATTERING = MAX_SCATTERING = 1.
 *
 * Units. E is the irradiance of the collimated beam on a plane normal to
 * the beam: the formulas follow from the radiance leaving at cosine μ,
 *   L_R = ∫_0^d σs (F/μ0) e^{−σt z/μ0} p(Θ) e^{−σt z/μ} dz/μ,
 * where F = E μ0 is the power the beam brings per unit area of the slab's
 * face (the beam's flux density across the face) and F/μ0 the power per
 * unit area normal to the beam, which is what a unit volume intercepts per
 * unit length. The library's collimated area source spreads its power 1
 * uniformly over a rectangle of the face, so F = 1/area and E = 1/(area·μ0);
 * both are 1/area at normal incidence. Its orthographic value is the
 * outgoing radiance averaged over the pixel's area per unit emitted power,
 * i.e. the L above when the radiance is uniform over the pixel.
 *
 * Laterally infinite. The slab is a box 200 times as wide as it is thick
 * (100 mm for d = 0.5 mm). For single scattering the closed form is exact,
 * not approximate, when every once-scattered path that ends in the pixel
 * started inside the lit rectangle: the vertex lies at most d·tanθ from the
 * exit point and the entry point at most d·tanθ0 from the vertex, so the
 * lit rectangle must contain the pixel grown by d(tanθ + tanθ0)
 * ≤ 0.5·(1.732 + 0.75) = 1.24 mm here. The pixel is [-3, 3]² and the lit
 * rectangle [-5, 5]²: a 2 mm margin. */
#include <math.h>

#include "validation.h"

/* 6 directions with normal incidence, 8 with oblique incidence. */
#define COMPARISONS 14

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0004)

static const double slab_d = 0.5;                      /* mm */
static const double sig_a = 0.3, sig_s = 0.7, hg_g = 0.5; /* σt = 1/mm: τ = 0.5, a = 0.7 */
static const double lit = 5.0;                         /* lit rectangle [-lit, lit]² */
static const double pix = 3.0;                         /* pixel [-pix, pix]² */

static double hg(double g, double cos_theta) {
  double d = 1.0 + g * g - 2.0 * g * cos_theta;
  return (1.0 - g * g) / (4.0 * VAL_PI * d * sqrt(d));
}

/* Prahl's once-scattered radiance for a beam travelling along `beam` with
 * irradiance E (normal to the beam) leaving along `out`. */
static double prahl(const double beam[3], const double out[3], double E) {
  double tau = (sig_a + sig_s) * slab_d, a = sig_s / (sig_a + sig_s);
  double mu0 = -beam[2], mu = fabs(out[2]);
  double p = hg(hg_g, beam[0] * out[0] + beam[1] * out[1] + beam[2] * out[2]);
  if (out[2] > 0.0) return a * E * p * mu0 / (mu + mu0) * (1.0 - exp(-tau * (1.0 / mu + 1.0 / mu0)));
  if (mu == mu0) return a * E * p * (tau / mu) * exp(-tau / mu);
  return a * E * p * mu0 / (mu0 - mu) * (exp(-tau / mu0) - exp(-tau / mu));
}

typedef struct direction_case {
  const char *name;
  double out[3];
} direction_case_t;

/* Renders the once-scattered radiance for a collimated area source along
 * `beam` and one single-pixel orthographic sensor per direction, and
 * compares each with Prahl's closed form. Returns the number of failures. */
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
  hetinv_sensor_t *sensors[8] = {NULL};
  assert_true(n <= 8);
  for (int i = 0; i < n; ++i) {
    hetinv_face_t face = dirs[i].out[2] > 0.0 ? HETINV_FACE_Z_MAX : HETINV_FACE_Z_MIN;
    assert_ok(hetinv_sensor_create_orthographic(m, face, dirs[i].out, (double[]){-pix, -pix},
                                                (double[]){2 * pix, 2 * pix}, 1, 1, &sensors[i]));
    assert_ok(hetinv_measurements_add(set, source, sensors[i], steady, NULL));
  }
  hetinv_estimator_t *est = val_estimator(ctx, 8e6);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, 1));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, 1));
  double v[8], se[8];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, NULL, (size_t)n));
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_ok(hetinv_estimator_get_stats(est, &stats));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)stats.photons, stats.seconds);

  double mu0 = -beam[2];
  double E = 1.0 / ((2 * lit) * (2 * lit) * mu0); /* see the file comment */
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  for (int i = 0; i < n; ++i) {
    char what[64];
    snprintf(what, sizeof what, "%s_mu%.2f_%s", dirs[i].out[2] > 0 ? "L_R" : "L_T",
             fabs(dirs[i].out[2]), dirs[i].name);
    failures += !val_compare(case_id, what, prahl(beam, dirs[i].out, E), 0.0, v[i], se[i], z_max, seed);
  }
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  for (int i = 0; i < n; ++i) hetinv_sensor_destroy(&sensors[i]);
  hetinv_pathlength_destroy(&steady);
  hetinv_emitter_destroy(&source);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return failures;
}

static const double s08 = 0.6, s05 = 0.86602540378443864676; /* sinθ at μ = 0.8, 0.5 */

static void normal_incidence_matches_prahl(void **state) {
  (void)state;
  const double beam[3] = {0.0, 0.0, -1.0};
  const direction_case_t dirs[] = {
      {"normal", {0.0, 0.0, 1.0}},  {"phi0", {s08, 0.0, 0.8}},  {"phi0", {s05, 0.0, 0.5}},
      {"normal", {0.0, 0.0, -1.0}}, {"phi0", {s08, 0.0, -0.8}}, {"phi90", {0.0, s05, -0.5}},
  };
  val_assert_all_passed(compare_directions("SS_mu0_1.00", beam, dirs, 6));
}

/* μ0 = 0.8: the beam travels along (0.6, 0, -0.8). */
static void oblique_incidence_matches_prahl(void **state) {
  (void)state;
  const double beam[3] = {s08, 0.0, -0.8};
  const direction_case_t dirs[] = {
      {"normal", {0.0, 0.0, 1.0}},
      {"phi0", {s08, 0.0, 0.8}},
      {"backscatter", {-s08, 0.0, 0.8}}, /* Θ = 180° */
      {"phi90", {0.0, s05, 0.5}},
      {"forward", {s08, 0.0, -0.8}},     /* μ = μ0, Θ = 0 */
      {"phi90", {0.0, s08, -0.8}},       /* μ = μ0, Θ ≠ 0 */
      {"phi0", {s05, 0.0, -0.5}},
      {"normal", {0.0, 0.0, -1.0}},
  };
  val_assert_all_passed(compare_directions("SS_mu0_0.80", beam, dirs, 8));
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(normal_incidence_matches_prahl),
      cmocka_unit_test(oblique_incidence_matches_prahl),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
