/* Scattering orders add up: with HETINV_ESTIMATOR_MIN_SCATTERING and
 * MAX_SCATTERING selecting the light scattered k times,
 *   I(k = 0) + I(k = 1) + I(k = 2) + I(k ≥ 3) = I(all orders),
 * where k = 0 is the unscattered light (a hemispherical detector's
 * ballistic part; orthographic values have none). Each order is rendered
 * with its own random stream, so the five renders are independent and the
 * errors add in quadrature.
 *
 * Small heterogeneous medium, η = 1.3; hemispherical detectors on the top
 * face (reflection, including the unscattered light the bottom face
 * reflects back) and the bottom face (transmission), a 2 × 1 orthographic
 * sensor on the top face, and a box pathlength bin of the bottom detector. */
#include <math.h>

#include "validation.h"

#define VALUES 5
#define COMPARISONS VALUES

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0051)

typedef struct orders_out {
  double v[VALUES], se[VALUES], ballistic[VALUES];
  double photons;
} orders_out_t;

static orders_out_t render(int32_t min_k, int32_t max_k, uint32_t stream) {
  hetinv_context_t *ctx = val_context(seed, 1);
  const val_ranges_t ranges = {{0.1, 0.5}, {0.5, 2.0}, {0.0, 0.8}};
  hetinv_medium_t *m = val_heterogeneous(ctx, (double[]){0, 0, 0}, (double[]){2.0, 2.0, 1.0},
                                         (int32_t[]){2, 2, 2}, &ranges, seed, 1.3, 1.0);
  assert_ok(hetinv_medium_commit(m));
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.9, 1.1, 2.0}, (double[]){0.1, -0.1, -1.0}, &beam));
  hetinv_sensor_t *s[3];
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &s[0]));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &s[1]));
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0.3, 0.1, 1.0},
                                              (double[]){0.2, 0.4}, (double[]){0.8, 1.2}, 2, 1, &s[2]));
  hetinv_pathlength_t *steady = NULL, *bin = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 1, (double[]){2.0}, 1.0, &bin));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  for (int i = 0; i < 3; ++i) assert_ok(hetinv_measurements_add(set, beam, s[i], steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, s[1], bin, NULL));
  hetinv_estimator_t *est = val_estimator(ctx, 8e5);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MIN_SCATTERING, min_k));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, max_k));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, stream));
  orders_out_t out;
  assert_ok(hetinv_estimator_render(est, m, set, out.v, out.se, out.ballistic, VALUES));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  out.photons = (double)st.photons;
  printf("render (orders %d..%d): %llu photons in %.2f s\n", (int)min_k, (int)max_k,
         (unsigned long long)st.photons, st.seconds);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_pathlength_destroy(&bin);
  for (int i = 0; i < 3; ++i) hetinv_sensor_destroy(&s[i]);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return out;
}

static void scattering_orders_add_up_to_all_orders(void **state) {
  (void)state;
  /* MAX_SCATTERING 0 means unlimited; MIN = MAX = 0 keeps every order. */
  orders_out_t all = render(0, 0, 0);
  orders_out_t k0 = render(0, 0, 1); /* only its ballistic channel is used */
  orders_out_t k1 = render(1, 1, 2), k2 = render(2, 2, 3), k3 = render(3, 0, 4);
  static const char *names[VALUES] = {"hemi_top", "hemi_bottom", "pixel0", "pixel1",
                                      "hemi_bottom_bin_1.5_2.5"};
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  for (int i = 0; i < VALUES; ++i) {
    /* The order-0 part: a hemispherical detector's ballistic output. Each
     * photon adds a weight b in [0, 1] to it, so b² ≤ b, var(b) ≤ E[b] -
     * E[b]², and sqrt(mean (1 - mean) / N) bounds its standard error.
     * Orthographic values never hold unscattered light. */
    int ortho = i == 2 || i == 3;
    double b = ortho ? 0.0 : k0.ballistic[i], b_se = sqrt(b * (1.0 - b) / k0.photons);
    double sum = b + k1.v[i] + k2.v[i] + k3.v[i];
    double se = sqrt(b_se * b_se + k1.se[i] * k1.se[i] + k2.se[i] * k2.se[i] + k3.se[i] * k3.se[i]);
    char what[64];
    snprintf(what, sizeof what, "sum_of_orders_%s", names[i]);
    failures += !val_compare("SO", what, all.v[i], all.se[i], sum, se, z_max, seed);
  }
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(scattering_orders_add_up_to_all_orders),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
