/* Energy conservation: every photon's power ends as specular reflection at
 * the first surface, absorption, escape through a face, or (with
 * HETINV_ESTIMATOR_MAX_SCATTERING) truncation, so
 *   specular + absorbed + Σ_faces escaped (+ truncated) = 1.
 * Without Russian roulette this holds for every photon, so the statistics
 * must add up to 1 to rounding; with roulette it holds in expectation only,
 * and is compared within the error bar.
 *
 * The medium is a small heterogeneous box with a mismatched boundary
 * (η = 1.4: Fresnel reflection and total internal reflection at every face;
 * and once η = 1 inside a denser η_out = 1.33),
 * one vacuum voxel and one purely absorbing voxel, lit by three emitters of
 * different kinds (an oblique pencil beam, a collimated area source on a
 * side face, a diffuse point source on the bottom face). */
#include <float.h>
#include <math.h>

#include "validation.h"

/* One statistical comparison: the balance with roulette. */
#define COMPARISONS 1

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed005a)

/* Rounding bound of the exact balances: the statistics are sums of ~N·k
 * terms of total ≤ 1 (N = 3e5 photons per emitter, k ≲ 30 terms per
 * photon), and recursive summation of n non-negative terms errs by at most
 * n·ε of their total: N·k·ε ≤ 3e5·30·2.2e-16 = 2e-9. A photon that lost or
 * gained its weight w would show as w/N ≥ 3e-6·w. */
#define ROUNDING_TOL 2e-9

typedef struct scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *emitters[3];
  hetinv_sensor_t *faces[6];
  hetinv_pathlength_t *steady;
  hetinv_measurements_t *set;
} scene_t;

static const double box_lo[3] = {0.0, 0.0, 0.0}, box_hi[3] = {3.0, 2.5, 2.0};

/* Three emitters, each with a hemispherical detector on every whole face. */
static scene_t make_scene_ior(double eta, double eta_out) {
  scene_t s = {0};
  s.ctx = val_context(seed, 1);
  const val_ranges_t ranges = {{0.1, 0.8}, {1.0, 6.0}, {-0.3, 0.8}};
  s.medium = val_heterogeneous(s.ctx, box_lo, box_hi, (int32_t[]){4, 3, 3}, &ranges, seed, eta, eta_out);
  assert_ok(hetinv_medium_set_voxel(s.medium, 1, 1, 1, 0.0, 0.0, 0.0)); /* vacuum */
  assert_ok(hetinv_medium_set_voxel(s.medium, 2, 1, 1, 1.5, 0.0, 0.0)); /* absorbing only */
  assert_ok(hetinv_medium_commit(s.medium));
  assert_ok(hetinv_emitter_create_ideal(s.medium, (double[]){1.0, 1.0, 3.0},
                                        (double[]){0.3, 0.2, -1.0}, &s.emitters[0]));
  assert_ok(hetinv_emitter_create_area(s.medium, HETINV_FACE_X_MIN, (double[]){1.0, -0.2, 0.4},
                                       (double[]){0.5, 0.5}, (double[]){2.0, 1.5}, 1, 1, NULL,
                                       &s.emitters[1]));
  assert_ok(hetinv_emitter_create_diffuse(s.medium, HETINV_FACE_Z_MIN, (double[]){2.0, 1.2},
                                          &s.emitters[2]));
  assert_ok(hetinv_pathlength_create_steady(s.ctx, &s.steady));
  assert_ok(hetinv_measurements_create(s.ctx, &s.set));
  for (int f = 0; f < 6; ++f) {
    assert_ok(hetinv_sensor_create_hemispherical(s.medium, f, NULL, NULL, &s.faces[f]));
  }
  for (int e = 0; e < 3; ++e) {
    for (int f = 0; f < 6; ++f) {
      assert_ok(hetinv_measurements_add(s.set, s.emitters[e], s.faces[f], s.steady, NULL));
    }
  }
  return s;
}

static scene_t make_scene(void) { return make_scene_ior(1.4, 1.0); }

static void free_scene(scene_t *s) {
  hetinv_measurements_destroy(&s->set);
  hetinv_pathlength_destroy(&s->steady);
  for (int f = 0; f < 6; ++f) hetinv_sensor_destroy(&s->faces[f]);
  for (int e = 0; e < 3; ++e) hetinv_emitter_destroy(&s->emitters[e]);
  hetinv_medium_destroy(&s->medium);
  hetinv_context_destroy(&s->ctx);
}

/* Renders the scene; values[e·6 + f] is emitter e's escape through face f. */
static hetinv_render_stats_t render(scene_t *s, double roulette_weight, double max_scattering,
                                    double values[18], double se[18]) {
  hetinv_estimator_t *est = val_estimator(s->ctx, 3e5);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_ROULETTE_WEIGHT, roulette_weight));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, max_scattering));
  assert_ok(hetinv_estimator_render(est, s->medium, s->set, values, se, NULL, 18));
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_ok(hetinv_estimator_get_stats(est, &stats));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)stats.photons, stats.seconds);
  hetinv_estimator_destroy(&est);
  return stats;
}

static double balance(const hetinv_render_stats_t *st) {
  double sum = st->specular + st->absorbed + st->truncated;
  for (int f = 0; f < 6; ++f) sum += st->escaped[f];
  return sum;
}

static void energy_balances_exactly_without_roulette(void **state) {
  (void)state;
  scene_t s = make_scene();
  double v[18], se[18];
  hetinv_render_stats_t st = render(&s, 0.0, 0.0, v, se);
  int failures = 0;
  failures += !val_check_exact("E1", "balance_no_roulette", 1.0, balance(&st), ROUNDING_TOL, seed);
  failures += !val_check_exact("E1", "truncated_no_limit", 0.0, st.truncated, 0.0, seed);
  /* The hemispherical detectors over whole faces score the same escapes
   * the statistics count: their mean over the emitters is stats.escaped. */
  for (int f = 0; f < 6; ++f) {
    double mean = (v[f] + v[6 + f] + v[12 + f]) / 3.0;
    char what[48];
    snprintf(what, sizeof what, "hemispherical_equals_escaped_face%d", f);
    failures += !val_check_exact("E1", what, st.escaped[f], mean, ROUNDING_TOL, seed);
  }
  free_scene(&s);
  val_assert_all_passed(failures);
}

static void energy_balances_exactly_with_truncation(void **state) {
  (void)state;
  scene_t s = make_scene();
  double v[18], se[18];
  hetinv_render_stats_t st = render(&s, 0.0, 3.0, v, se);
  int failures = 0;
  val_note("E2", "truncated_after_3", st.truncated, 0.0);
  failures += !(st.truncated > 0.0);
  failures += !val_check_exact("E2", "balance_max_scattering_3", 1.0, balance(&st),
                               ROUNDING_TOL, seed);
  free_scene(&s);
  val_assert_all_passed(failures);
}

/* A medium of lower index than its surroundings (η = 1, η_out = 1.33): part
 * of the diffuse source's light is totally reflected before it enters. */
static void energy_balances_exactly_into_a_lower_index(void **state) {
  (void)state;
  scene_t s = make_scene_ior(1.0, 1.33);
  double v[18], se[18];
  hetinv_render_stats_t st = render(&s, 0.0, 0.0, v, se);
  int failures = !val_check_exact("E4", "balance_eta1_in_eta_out1.33", 1.0, balance(&st),
                                  ROUNDING_TOL, seed);
  free_scene(&s);
  val_assert_all_passed(failures);
}

/* Aggressive roulette (below weight 0.05, survival 0.3) keeps the balance
 * in expectation. The components of the balance come from the same photons
 * and are correlated, and the render gives no covariances; so the error bar
 * of the sum is the spread of REPLICAS independent renders (different
 * random streams), and the threshold is Student's t with REPLICAS - 1
 * degrees of freedom. */
#define REPLICAS 32

static void energy_balances_on_average_with_roulette(void **state) {
  (void)state;
  scene_t s = make_scene();
  double v[18], se[18], sum = 0.0, sq = 0.0, seconds = 0.0;
  for (int r = 0; r < REPLICAS; ++r) {
    hetinv_estimator_t *e = val_estimator(s.ctx, 1e6 / REPLICAS);
    assert_ok(hetinv_estimator_set_param(e, HETINV_ESTIMATOR_ROULETTE_WEIGHT, 0.05));
    assert_ok(hetinv_estimator_set_param(e, HETINV_ESTIMATOR_ROULETTE_SURVIVAL, 0.3));
    assert_ok(hetinv_estimator_set_param(e, HETINV_ESTIMATOR_STREAM, r));
    assert_ok(hetinv_estimator_render(e, s.medium, s.set, v, se, NULL, 18));
    hetinv_render_stats_t st = {.size = sizeof st};
    assert_ok(hetinv_estimator_get_stats(e, &st));
    seconds += st.seconds;
    hetinv_estimator_destroy(&e);
    double b = balance(&st);
    sum += b;
    sq += b * b;
  }
  printf("render: %d replicas in %.2f s\n", REPLICAS, seconds);
  double mean = sum / REPLICAS;
  double var = (sq - sum * mean) / (REPLICAS - 1);
  double se_mean = sqrt(var > 0.0 ? var / REPLICAS : 0.0);
  int failures = !val_compare("E3", "balance_roulette", 1.0, 0.0, mean, se_mean,
                              val_t_max(REPLICAS - 1, COMPARISONS), seed);
  free_scene(&s);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(energy_balances_exactly_without_roulette),
      cmocka_unit_test(energy_balances_exactly_with_truncation),
      cmocka_unit_test(energy_balances_exactly_into_a_lower_index),
      cmocka_unit_test(energy_balances_on_average_with_roulette),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
