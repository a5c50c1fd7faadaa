#include "loss_problem.h"

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
