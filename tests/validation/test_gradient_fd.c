/* Score-function gradients (hetinv_estimator_gradient, Eqs. 17–20) against
 * central finite differences of the forward estimator with common random
 * numbers, on a small heterogeneous medium with a refractive boundary.
 *
 * Scene. A 3 × 3 × 3 grid of 0.5 mm voxels (box [0, 1.5]³ mm), η = 1.3 in
 * air, every voxel different: σa in [0.2, 1], σs in [1, 5] /mm, g in
 * [0.1, 0.6] (a fixed table drawn once). A pencil beam enters the top face
 * (z = 1.5) at its centre at normal incidence. Three measurements, all from
 * the same photons:
 *   0 "ortho":  one orthographic pixel over [0.25, 1.25]² of the top face,
 *               exit direction (0.3, 0, 1)/|·| (oblique: refraction and
 *               Fresnel transmittance of the connection), steady state;
 *   1 "bin":    the same pixel, box pathlength window [1, 3) mm;
 *   2 "hemi":   a hemispherical detector over the whole bottom face (total
 *               transmittance, ballistic light included).
 * Derivatives with respect to σa, σs and g of four voxels: the interior
 * voxel (1,1,1), the top voxel under the beam (1,1,2), a top corner voxel
 * (0,2,2) and the bottom voxel under the beam (1,1,0): 4·3·3 = 36
 * comparisons, and 12 more for "hemi" measured alone (below).
 *
 * Gradient. hetinv_estimator_gradient with a one-hot cotangent on value n
 * gives ∂I_n/∂π for every voxel at once (identity map of all three
 * parameters); its standard error comes from 256 batch means (255 dof).
 * The grid is tracked by delta tracking (its cost model picks it for these
 * voxels), but a score pass whose plan has a vertex sensor (the pixel's
 * next-event connections) steps voxel by voxel; "hemi" alone, a set whose
 * plan has only an exit sensor, takes the other way: delta-tracked flights
 * logged whole and split into voxels when the path scores. Its gradient is
 * compared with the same finite differences.
 *
 * Finite difference. D = (I(π + h) − I(π − h)) / 2h, both renders with the
 * same random stream (common random numbers: the photons keep their random
 * numbers, and for small h most of their paths, so the difference is
 * mostly a smooth change of weights and positions; its variance still
 * grows like 1/h, from the paths whose discrete events flip). Its standard
 * error is measured, not assumed: D is repeated over M = 64 independent
 * streams (HETINV_ESTIMATOR_STREAM 0..63, each with 1/M of the photons)
 * and the spread of the M values gives it (63 dof). The gradient uses
 * stream 1000, independent of all of them.
 *
 * Step. E[D] is exactly the central difference of the expected values: it
 * differs from the derivative by h²·I'''/6 + O(h^4). h = 10 % of σ, and
 * h = 0.05 for g (the phase function is strongly curved in g). Checked
 * during development with 8× the photons of this test: D(h) − D(h/2)
 * (3/4 of the truncation bias of D(h) when the h² term dominates, and
 * precisely estimated because both share their random numbers) was
 * consistent with zero for all 36 comparisons (within 1.8 of its own
 * error, that error being 0.26–0.52 of this test's FD error). With larger
 * steps, σ ± 20 % (2×) and g ± 0.2 (4×), the bias became visible: up to
 * 0.6 % of the derivative for σ and 1–7 % for g, which scale by (1/2)² and
 * (1/4)² to ≤ 0.15 % and ≤ 0.5 % here, against FD errors of 1–5 %.
 *
 * Threshold. z = (grad − D) / sqrt(se_grad² + se_D²) is Student-t with the
 * Welch–Satterthwaite degrees of freedom; the bound is the two-sided t
 * quantile at VAL_FAMILY_ALPHA / 36 (Bonferroni over the 36 comparisons,
 * which need not be independent: the three values share photons and the
 * perturbations share streams). Over 5 seeds during development the mean
 * z² was 1.2 (1.03 expected for t with 63 dof) and the largest |z| 3.0:
 * path scores are heavy-tailed, and over 30 independent repetitions the
 * batch error of the g-derivative of the hemispherical value understated
 * the actual spread by up to ~30 % (the FD errors were accurate). */
#include <math.h>

#include "test_gradient_common.h"

#define COMPARISONS 48
#define STREAMS 64            /* independent CRN finite differences */
#define FD_PHOTONS 2.4e5      /* per side of each difference, all streams together */
#define GRAD_PHOTONS 2e5      /* per gradient call */
#define GRAD_STREAM 1000      /* the gradient's paths: independent of streams 0..63 */
#define VALUES 3
#define NVOX 4

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0a01)

static const char *const value_name[VALUES] = {"ortho", "bin", "hemi"};
static const int32_t voxel[NVOX][3] = {{1, 1, 1}, {1, 1, 2}, {0, 2, 2}, {1, 1, 0}};

typedef struct scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *pixel, *hemi;
  hetinv_pathlength_t *steady, *bin;
  hetinv_measurements_t *set;
  hetinv_measurements_t *hemi_only; /* value 2 of set alone */
} scene_t;

static void scene_build(scene_t *s) {
  s->ctx = val_context(seed, 1);
  assert_ok(hetinv_medium_create(s->ctx, (double[]){0, 0, 0}, (double[]){1.5, 1.5, 1.5},
                                 (int32_t[]){3, 3, 3}, &s->medium));
  assert_ok(hetinv_medium_set_ior(s->medium, 1.3, 1.0));
  uint64_t table = 0x3a3a3; /* the medium is fixed, whatever the test seed */
  for (int32_t z = 0; z < 3; ++z) {
    for (int32_t y = 0; y < 3; ++y) {
      for (int32_t x = 0; x < 3; ++x) {
        double sa = 0.2 + 0.8 * grad_uniform(&table);
        double ss = 1.0 + 4.0 * grad_uniform(&table);
        double g = 0.1 + 0.5 * grad_uniform(&table);
        assert_ok(hetinv_medium_set_voxel(s->medium, x, y, z, sa, ss, g));
      }
    }
  }
  assert_ok(hetinv_medium_commit(s->medium));
  assert_ok(hetinv_emitter_create_ideal(s->medium, (double[]){0.75, 0.75, 2.5}, (double[]){0, 0, -1},
                                        &s->beam));
  assert_ok(hetinv_sensor_create_orthographic(s->medium, HETINV_FACE_Z_MAX, (double[]){0.3, 0.0, 1.0},
                                              (double[]){0.25, 0.25}, (double[]){1.0, 1.0}, 1, 1,
                                              &s->pixel));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MIN, NULL, NULL, &s->hemi));
  assert_ok(hetinv_pathlength_create_steady(s->ctx, &s->steady));
  assert_ok(hetinv_pathlength_create_bins(s->ctx, HETINV_WINDOW_BOX, 1, (double[]){2.0}, 2.0, &s->bin));
  assert_ok(hetinv_measurements_create(s->ctx, &s->set));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->pixel, s->steady, NULL));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->pixel, s->bin, NULL));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->hemi, s->steady, NULL));
  assert_int_equal(hetinv_measurements_value_count(s->set), VALUES);
  assert_ok(hetinv_measurements_create(s->ctx, &s->hemi_only));
  assert_ok(hetinv_measurements_add(s->hemi_only, s->beam, s->hemi, s->steady, NULL));
}

static void scene_destroy(scene_t *s) {
  hetinv_measurements_destroy(&s->hemi_only);
  hetinv_measurements_destroy(&s->set);
  hetinv_pathlength_destroy(&s->bin);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_sensor_destroy(&s->hemi);
  hetinv_sensor_destroy(&s->pixel);
  hetinv_emitter_destroy(&s->beam);
  hetinv_medium_destroy(&s->medium);
  hetinv_context_destroy(&s->ctx);
}

static void gradient_matches_crn_finite_differences(void **state) {
  (void)state;
  scene_t s;
  scene_build(&s);
  double t0 = grad_now();

  /* Finite differences: fd[v][p][n] over STREAMS streams. */
  hetinv_estimator_t *fd_est = grad_fd_estimator(s.ctx, FD_PHOTONS, STREAMS);
  double per_stream, fd_mean[NVOX][3][VALUES], fd_se[NVOX][3][VALUES], h_used[NVOX][3];
  assert_ok(hetinv_estimator_get_param(fd_est, HETINV_ESTIMATOR_PHOTONS, &per_stream));
  for (int v = 0; v < NVOX; ++v) {
    grad_fd_voxel(fd_est, s.medium, s.set, voxel[v], VALUES, STREAMS, fd_mean[v][0], fd_se[v][0], h_used[v]);
  }
  hetinv_estimator_destroy(&fd_est);
  double t1 = grad_now();

  /* Gradients: one call per value, with a one-hot cotangent. */
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(s.medium, HETINV_FREE_ALL, &map));
  hetinv_estimator_t *est = val_estimator(s.ctx, GRAD_PHOTONS);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, GRAD_STREAM));
  double grad[VALUES][81], grad_se[VALUES][81];
  for (int n = 0; n < VALUES; ++n) {
    double cot[VALUES] = {0};
    cot[n] = 1.0;
    assert_ok(hetinv_estimator_gradient(est, s.medium, s.set, cot, VALUES, map, grad[n], grad_se[n], 81));
  }
  double alone[81], alone_se[81], one = 1.0;
  assert_ok(hetinv_estimator_gradient(est, s.medium, s.hemi_only, &one, 1, map, alone, alone_se, 81));
  double photons;
  assert_ok(hetinv_estimator_get_param(est, HETINV_ESTIMATOR_PHOTONS, &photons));
  double t2 = grad_now();
  printf("finite differences: %d x 2 renders of %.0f photons x %d streams in %.1f s; "
         "gradients: %d calls of %.0f photons in %.1f s\n",
         NVOX * 3, per_stream, STREAMS, t1 - t0, VALUES + 1, photons, t2 - t1);

  int failures = 0;
  for (int v = 0; v < NVOX; ++v) {
    size_t k = (size_t)voxel[v][0] + 3 * ((size_t)voxel[v][1] + 3 * (size_t)voxel[v][2]);
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      for (int n = 0; n < VALUES; ++n) {
        char name[96];
        snprintf(name, sizeof name, "fd/%s/%s/(%d,%d,%d)/h=%.4g", value_name[n], hetinv_param_name(p),
                 (int)voxel[v][0], (int)voxel[v][1], (int)voxel[v][2], h_used[v][p]);
        failures += !grad_compare(name, fd_mean[v][p][n], fd_se[v][p][n], STREAMS - 1.0,
                                  grad[n][(size_t)p * 27 + k], grad_se[n][(size_t)p * 27 + k],
                                  GRAD_BATCH_DOF, COMPARISONS, seed);
      }
      char name[96];
      snprintf(name, sizeof name, "fd/hemi alone/%s/(%d,%d,%d)/h=%.4g", hetinv_param_name(p),
               (int)voxel[v][0], (int)voxel[v][1], (int)voxel[v][2], h_used[v][p]);
      failures += !grad_compare(name, fd_mean[v][p][2], fd_se[v][p][2], STREAMS - 1.0,
                                alone[(size_t)p * 27 + k], alone_se[(size_t)p * 27 + k],
                                GRAD_BATCH_DOF, COMPARISONS, seed);
    }
  }
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  scene_destroy(&s);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(gradient_matches_crn_finite_differences),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
