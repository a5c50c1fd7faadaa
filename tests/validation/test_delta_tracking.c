/* Delta (Woodcock) tracking of the forward pass against regular tracking,
 * on a strongly heterogeneous medium: a checkerboard of voxels whose σt
 * differs 100× (5 or, in every other layer, 2 against 0.05 /mm; g 0.7 and
 * 0.1), with columns of vacuum voxels, η = 1.4 in air (Fresnel reflections at every exit and along the
 * next-event connections' specular chains). An oblique pencil beam enters
 * the top face. Compared, each within the two renders' combined standard
 * errors (independent streams):
 *   the total reflectance (hemispherical, top face) and transmittance
 *   (bottom face), a 2 × 2 orthographic sensor on the top face in three
 *   box pathlength bins, the same sensor steady, and the absorbed fraction.
 * The test forces each tracking in turn on the pass (white box), whatever
 * hv_grid_prefers_delta would choose. The voxels of σt = 2, whose
 * tentative collisions are real with probability 0.4, make the comparison
 * sensitive to the acceptance test: with that probability 5 % too high
 * (σ̄ taken as 0.95 σ̄ in the test) the transmittance is off by many
 * standard errors. Runs in about 5 s (Release). */
#include <math.h>

#include "validation.h"

#include "estimator/pass.h"

#define SEED UINT64_C(0xde17a7)
#define VALUES 18 /* 1 + 1 + 4 × 3 bins + 4 steady */
#define COMPARISONS (VALUES + 1)

static uint64_t seed;
static const double box_lo[3] = {0.0, 0.0, 0.0}, box_hi[3] = {2.0, 2.0, 1.5};
enum { NX = 8, NY = 8, NZ = 6 };

typedef struct render_out {
  double v[VALUES], se[VALUES];
  double absorbed, absorbed_se;
  int delta_chosen;
} render_out_t;

static render_out_t render(int delta, uint32_t stream) {
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *m = val_medium(ctx, box_lo, box_hi, (int32_t[]){NX, NY, NZ}, 0.0, 0.0, 0.0, 1.4, 1.0, 0);
  for (int32_t z = 0; z < NZ; ++z) {
    for (int32_t y = 0; y < NY; ++y) {
      for (int32_t x = 0; x < NX; ++x) {
        int dense = (x + y + z) % 2 == 0;
        int vacuum = x % 3 == 1 && y % 3 == 2; /* columns through the whole depth */
        double st = dense ? (z % 2 == 0 ? 5.0 : 2.0) : 0.05; /* the majorant, 40 % of it, 1 % */
        double sa = vacuum ? 0.0 : 0.1 * st, ss = vacuum ? 0.0 : 0.9 * st;
        assert_ok(hetinv_medium_set_voxel(m, x, y, z, sa, ss, dense ? 0.7 : 0.1));
      }
    }
  }
  assert_ok(hetinv_medium_commit(m));
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.9, 1.1, 1.5}, (double[]){0.3, -0.2, -1.0}, &beam));
  hetinv_sensor_t *s[3] = {NULL};
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &s[0]));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &s[1]));
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){-0.2, 0.3, 1.0},
                                              (double[]){0.4, 0.4}, (double[]){0.6, 0.6}, 2, 2, &s[2]));
  hetinv_pathlength_t *steady = NULL, *bins = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 3, (double[]){0.5, 1.5, 3.0}, 1.0, &bins));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, s[0], steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, s[1], steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, s[2], bins, NULL));
  assert_ok(hetinv_measurements_add(set, beam, s[2], steady, NULL));
  assert_int_equal(hetinv_measurements_value_count(set), VALUES);
  hetinv_estimator_t *est = val_estimator(ctx, 2e5);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, stream));

  render_out_t out;
  hv_pass_t pass;
  assert_ok(hv_pass_begin(est, m, set, VALUES, &pass));
  out.delta_chosen = pass.tracer.delta;
  pass.tracer.delta = delta;
  if (delta && pass.grid.majorant > 0.0) assert_true(pass.grid.majorant == 5.0);
  assert_ok(hv_forward_run(est, &pass, out.v, out.se, NULL, VALUES));
  hv_pass_end(&pass);

  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render (%s tracking): %llu photons in %.2f s\n", delta ? "delta" : "regular",
         (unsigned long long)st.photons, st.seconds);
  out.absorbed = st.absorbed;
  out.absorbed_se = st.absorbed_std_error;
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_pathlength_destroy(&bins);
  for (int i = 0; i < 3; ++i) hetinv_sensor_destroy(&s[i]);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return out;
}

static void delta_matches_regular(void **state) {
  (void)state;
  render_out_t regular = render(0, 0);
  render_out_t delta = render(1, 1);
  printf("the library's choice for this grid: %s tracking\n", regular.delta_chosen ? "delta" : "regular");
  static const char *names[VALUES] = {
      "reflectance", "transmittance", "ortho_p0_bin0.5", "ortho_p1_bin0.5", "ortho_p2_bin0.5",
      "ortho_p3_bin0.5", "ortho_p0_bin1.5", "ortho_p1_bin1.5", "ortho_p2_bin1.5", "ortho_p3_bin1.5",
      "ortho_p0_bin3", "ortho_p1_bin3", "ortho_p2_bin3", "ortho_p3_bin3", "ortho_p0", "ortho_p1",
      "ortho_p2", "ortho_p3"};
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  for (int i = 0; i < VALUES; ++i) {
    assert_true(regular.se[i] > 0.0); /* every value is reached: a real comparison */
    failures += !val_compare("DT", names[i], regular.v[i], regular.se[i], delta.v[i], delta.se[i], z_max, seed);
  }
  failures += !val_compare("DT", "absorbed", regular.absorbed, regular.absorbed_se, delta.absorbed,
                           delta.absorbed_se, z_max, seed);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(delta_matches_regular),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
