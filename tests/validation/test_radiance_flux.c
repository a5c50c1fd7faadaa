/* Radiance integrated over the exit directions equals flux.
 *
 * The flux leaving a region A of a face is
 *   Φ = ∫_A ∫_hemisphere L(x, ω) cosθ dω dA = A ∫ V(ω) cosθ dω,
 * V(ω) being an orthographic sensor's value (radiance averaged over a pixel
 * covering A) in direction ω, and Φ what a hemispherical detector over A
 * measures. The boundary is mismatched (η = 1.3), so V(ω) comes from
 * next-event connections through the sensor's refracted direction with
 * Fresnel transmittance and the specular chains of every face, while the
 * detector counts photons that crossed the boundary by random Fresnel
 * choices: two independent ways through the boundary code.
 *
 * The direction integral is done by stratified Monte Carlo rather than a
 * fixed quadrature, so that it carries no quadrature bias at all (V has
 * kinks where other faces turn to total internal reflection): with
 * s = cos²θ, ∫ V cosθ dω = π E[V] for (s, φ) uniform on [0,1) × [0,2π).
 * The square is cut into H equal strata, with two independent random
 * directions in each; every direction has its own emitter (an identical
 * pencil beam: distinct emitters get independent photons), so the
 * per-direction values are independent, and
 *   Φ̂ = (πA/H) Σ_h (V_h1 + V_h2)/2,  var(Φ̂) = (πA/H)² Σ_h (V_h1 - V_h2)²/4
 * is unbiased with an unbiased variance that includes both the photon
 * noise and the direction sampling. Unscattered light is left out of both
 * sides (HETINV_ESTIMATOR_MIN_SCATTERING = 1): it is a Dirac in direction,
 * reported apart from orthographic values. */
#include <math.h>
#include <stdlib.h>

#include "validation.h"

#define COMPARISONS 2 /* a region of the top face, one of a side face */
#define S_STRATA 16
#define PHI_STRATA 16
#define STRATA (S_STRATA * PHI_STRATA)
#define DIRECTIONS (2 * STRATA)

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed005c)

static const double box_lo[3] = {0.0, 0.0, 0.0}, box_hi[3] = {3.0, 3.0, 1.5};
static const val_ranges_t ranges = {{0.3, 0.8}, {1.0, 4.0}, {0.0, 0.6}};
static const double beam_origin[3] = {1.4, 1.6, 3.0}, beam_dir[3] = {0.1, -0.15, -1.0};

/* Compares A ∫ V cosθ dω with the hemispherical flux through the region
 * [lo, hi] of `face`; `stream` is the first of the two random streams the
 * comparison uses. Returns 1 on failure. */
static int compare_region(const char *name, hetinv_face_t face, const double lo[2],
                          const double hi[2], uint32_t stream) {
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *m = val_heterogeneous(ctx, box_lo, box_hi, (int32_t[]){3, 3, 2}, &ranges, seed, 1.3, 1.0);
  assert_ok(hetinv_medium_commit(m));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));

  /* The hemispherical detector over A. */
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, beam_origin, beam_dir, &beam));
  hetinv_sensor_t *hemi = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(m, face, lo, hi, &hemi));
  hetinv_measurements_t *flux_set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &flux_set));
  assert_ok(hetinv_measurements_add(flux_set, beam, hemi, steady, NULL));
  hetinv_estimator_t *est = val_estimator(ctx, 3e6);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, 1));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, stream));
  double flux, flux_se;
  assert_ok(hetinv_estimator_render(est, m, flux_set, &flux, &flux_se, NULL, 1));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render (hemispherical): %llu photons in %.2f s\n", (unsigned long long)st.photons, st.seconds);
  hetinv_estimator_destroy(&est);

  /* One single-pixel orthographic sensor covering A per direction, with the
   * direction's polar axis along the face's outward normal. */
  int axis = face / 2, au = axis == 0 ? 1 : 0, av = axis == 2 ? 1 : 2;
  double sign = (face & 1) ? 1.0 : -1.0;
  hetinv_emitter_t *beams[DIRECTIONS];
  hetinv_sensor_t *ortho[DIRECTIONS];
  hetinv_measurements_t *radiance_set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &radiance_set));
  uint64_t rng = seed ^ UINT64_C(0xd1b54a32d192ed03) ^ (uint64_t)face;
  const double size[2] = {hi[0] - lo[0], hi[1] - lo[1]};
  for (int h = 0; h < STRATA; ++h) {
    int is = h % S_STRATA, ip = h / S_STRATA;
    for (int k = 0; k < 2; ++k) {
      double s = (is + val_uniform(&rng)) / S_STRATA;
      double phi = 2.0 * VAL_PI * (ip + val_uniform(&rng)) / PHI_STRATA;
      double mu = sqrt(s), sin_theta = sqrt(1.0 - s);
      if (!(mu > 1e-9)) mu = 1e-9; /* s = 0 has probability 2^-53 */
      double out[3];
      out[axis] = sign * mu;
      out[au] = sin_theta * cos(phi);
      out[av] = sin_theta * sin(phi);
      int i = 2 * h + k;
      assert_ok(hetinv_emitter_create_ideal(m, beam_origin, beam_dir, &beams[i]));
      assert_ok(hetinv_sensor_create_orthographic(m, face, out, lo, size, 1, 1, &ortho[i]));
      assert_ok(hetinv_measurements_add(radiance_set, beams[i], ortho[i], steady, NULL));
    }
  }
  est = val_estimator(ctx, 800);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, 1));
  /* Another stream: the first emitter of this set has the same random key
   * as the detector's emitter above. */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, stream + 1));
  double v[DIRECTIONS], vse[DIRECTIONS];
  assert_ok(hetinv_estimator_render(est, m, radiance_set, v, vse, NULL, DIRECTIONS));
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render (orthographic): %llu photons in %.2f s\n", (unsigned long long)st.photons, st.seconds);
  hetinv_estimator_destroy(&est);

  double area = size[0] * size[1], c = VAL_PI * area / STRATA, sum = 0.0, var = 0.0;
  for (int h = 0; h < STRATA; ++h) {
    sum += 0.5 * (v[2 * h] + v[2 * h + 1]);
    var += 0.25 * (v[2 * h] - v[2 * h + 1]) * (v[2 * h] - v[2 * h + 1]);
  }
  /* The photon noise's share of the variance (the rest is the direction
   * sampling's), for information. */
  double photon_var = 0.0;
  for (int i = 0; i < DIRECTIONS; ++i) photon_var += 0.25 * vse[i] * vse[i];
  val_note(name, "photon_noise_se", c * sqrt(photon_var), 0.0);
  int failed = !val_compare(name, "integrated_radiance_vs_hemispherical_flux", flux, flux_se,
                            c * sum, c * sqrt(var), val_z_max(COMPARISONS), seed);
  for (int i = 0; i < DIRECTIONS; ++i) {
    hetinv_sensor_destroy(&ortho[i]);
    hetinv_emitter_destroy(&beams[i]);
  }
  hetinv_measurements_destroy(&radiance_set);
  hetinv_measurements_destroy(&flux_set);
  hetinv_sensor_destroy(&hemi);
  hetinv_emitter_destroy(&beam);
  hetinv_pathlength_destroy(&steady);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return failed;
}

/* A region of the lit top face (x, y). */
static void top_face_radiance_integrates_to_flux(void **state) {
  (void)state;
  val_assert_all_passed(compare_region("RF_top", HETINV_FACE_Z_MAX, (double[]){0.5, 0.75},
                                       (double[]){2.5, 2.25}, 0));
}

/* A region of a side face (face coordinates (y, z)). */
static void side_face_radiance_integrates_to_flux(void **state) {
  (void)state;
  val_assert_all_passed(compare_region("RF_side", HETINV_FACE_X_MAX, (double[]){0.5, 0.25},
                                       (double[]){2.0, 1.5}, 2));
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(top_face_radiance_integrates_to_flux),
      cmocka_unit_test(side_face_radiance_integrates_to_flux),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
