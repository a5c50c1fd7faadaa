#include "loss_problem.h"

#include <math.h>

#include "test_gradient_common.h"

const double loss_weight[LOSS_VALUES] = {1.0, 2.0, 0.5, 3.0};
const uint8_t loss_mask[LOSS_VALUES] = {1, 1, 1, 0};
static const double scale_measured[LOSS_VALUES] = {0.6, 1.4, 0.8, 0.1};

void loss_problem_build(loss_problem_t *p, uint64_t seed) {
  p->ctx = val_context(seed, 1);
  assert_ok(hetinv_medium_create(p->ctx, (double[]){0, 0, 0}, (double[]){2, 1, 1},
                                 (int32_t[]){2, 1, 1}, &p->medium));
  assert_ok(hetinv_medium_set_ior(p->medium, 1.3, 1.0));
  assert_ok(hetinv_medium_set_voxel(p->medium, 0, 0, 0, 0.5, 3.0, 0.3));
  assert_ok(hetinv_medium_set_voxel(p->medium, 1, 0, 0, 0.8, 2.0, 0.5));
  assert_ok(hetinv_medium_commit(p->medium));
  assert_ok(hetinv_emitter_create_ideal(p->medium, (double[]){0.5, 0.5, 1.0}, (double[]){0.3, 0.0, -1.0},
                                        &p->beam));
  assert_ok(hetinv_sensor_create_hemispherical(p->medium, HETINV_FACE_Z_MAX, NULL, NULL, &p->top));
  assert_ok(hetinv_sensor_create_hemispherical(p->medium, HETINV_FACE_Z_MIN, NULL, NULL, &p->bottom));
  assert_ok(hetinv_sensor_create_hemispherical(p->medium, HETINV_FACE_X_MAX, NULL, NULL, &p->side));
  assert_ok(hetinv_sensor_create_orthographic(p->medium, HETINV_FACE_Z_MAX, (double[]){0, 0, 1},
                                              (double[]){0, 0}, (double[]){2, 1}, 1, 1, &p->pixel));
  assert_ok(hetinv_pathlength_create_steady(p->ctx, &p->steady));
  assert_ok(hetinv_measurements_create(p->ctx, &p->set));
  assert_ok(hetinv_measurements_add(p->set, p->beam, p->top, p->steady, NULL));
  assert_ok(hetinv_measurements_add(p->set, p->beam, p->bottom, p->steady, NULL));
  assert_ok(hetinv_measurements_add(p->set, p->beam, p->side, p->steady, NULL));
  assert_ok(hetinv_measurements_add(p->set, p->beam, p->pixel, p->steady, NULL));
  assert_int_equal(hetinv_measurements_value_count(p->set), LOSS_VALUES);
  assert_ok(hetinv_param_map_create_identity(p->medium, HETINV_FREE_ALL, &p->map));
  assert_int_equal(hetinv_param_map_size(p->map), LOSS_K);
}

void loss_problem_destroy(loss_problem_t *p) {
  hetinv_param_map_destroy(&p->map);
  hetinv_measurements_destroy(&p->set);
  hetinv_pathlength_destroy(&p->steady);
  hetinv_sensor_destroy(&p->pixel);
  hetinv_sensor_destroy(&p->side);
  hetinv_sensor_destroy(&p->bottom);
  hetinv_sensor_destroy(&p->top);
  hetinv_emitter_destroy(&p->beam);
  hetinv_medium_destroy(&p->medium);
  hetinv_context_destroy(&p->ctx);
}

/* Sets the measured values: this medium's values (stream 60000) scaled. */
void loss_problem_set_measured(loss_problem_t *p, double measured[LOSS_VALUES]) {
  hetinv_estimator_t *est = val_estimator(p->ctx, 1e5);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 60000));
  double v[LOSS_VALUES];
  assert_ok(hetinv_estimator_render(est, p->medium, p->set, v, NULL, NULL, LOSS_VALUES));
  for (int n = 0; n < LOSS_VALUES; ++n) measured[n] = scale_measured[n] * v[n];
  assert_ok(hetinv_measurements_set_values(p->set, measured, NULL, LOSS_VALUES));
  assert_ok(hetinv_measurements_set_weights(p->set, loss_weight, LOSS_VALUES));
  assert_ok(hetinv_measurements_set_mask(p->set, loss_mask, LOSS_VALUES));
  hetinv_estimator_destroy(&est);
}

double loss_problem_reference(const loss_problem_t *p, double D[LOSS_STREAMS][LOSS_VALUES][LOSS_K],
                              double C[LOSS_STREAMS][LOSS_VALUES]) {
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(p->ctx, &est));
  double per_stream = floor(LOSS_REF_PHOTONS * (double)HETINV_VALIDATION_SCALE / LOSS_STREAMS + 0.5);
  if (per_stream < 64) per_stream = 64;
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, per_stream));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 2));
  hetinv_medium_t *plus[LOSS_K], *minus[LOSS_K];
  double h[LOSS_K];
  for (int k = 0; k < LOSS_K; ++k) {
    hetinv_param_t param;
    size_t cell;
    assert_ok(hetinv_param_map_entry(p->map, (size_t)k, &param, &cell));
    int32_t vox[3] = {(int32_t)cell, 0, 0};
    double v[3];
    assert_ok(hetinv_medium_get_voxel(p->medium, vox[0], 0, 0, &v[0], &v[1], &v[2]));
    h[k] = param == HETINV_PARAM_G ? 0.05 : 0.1 * v[param];
    plus[k] = grad_perturbed(p->medium, vox, param, v[param] + h[k]);
    minus[k] = grad_perturbed(p->medium, vox, param, v[param] - h[k]);
  }
  for (int j = 0; j < LOSS_STREAMS; ++j) {
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, j));
    for (int k = 0; k < LOSS_K; ++k) {
      double ip[LOSS_VALUES], im[LOSS_VALUES];
      assert_ok(hetinv_estimator_render(est, plus[k], p->set, ip, NULL, NULL, LOSS_VALUES));
      assert_ok(hetinv_estimator_render(est, minus[k], p->set, im, NULL, NULL, LOSS_VALUES));
      for (int n = 0; n < LOSS_VALUES; ++n) D[j][n][k] = (ip[n] - im[n]) / (2.0 * h[k]);
    }
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, LOSS_STREAMS + j));
    assert_ok(hetinv_estimator_render(est, p->medium, p->set, C[j], NULL, NULL, LOSS_VALUES));
  }
  for (int k = 0; k < LOSS_K; ++k) {
    hetinv_medium_destroy(&plus[k]);
    hetinv_medium_destroy(&minus[k]);
  }
  hetinv_estimator_destroy(&est);
  return per_stream;
}
