/* The small loss scene of small_scene.h. */
#include "small_scene.h"

void small_scene_init(small_scene_t *s, uint64_t seed, int batches) {
  *s = (small_scene_t){0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 2;
  init.seed = seed;
  assert_ok(hetinv_context_create(&init, &s->ctx));
  assert_ok(hetinv_medium_create(s->ctx, (double[]){0, 0, 0}, (double[]){10, 10, 10},
                                 (int32_t[]){2, 2, 2}, &s->medium));
  assert_ok(hetinv_medium_fill(s->medium, 0.05, 0.5, 0.3));
  assert_ok(hetinv_medium_set_ior(s->medium, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(s->medium));
  assert_ok(hetinv_emitter_create_ideal(s->medium, (double[]){4, 3, -1}, (double[]){0, 0, 1}, &s->beam));
  assert_ok(hetinv_sensor_create_orthographic(s->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){5, 5}, 2, 2, &s->ortho));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MAX, NULL, NULL, &s->transmit));
  assert_ok(hetinv_pathlength_create_steady(s->ctx, &s->steady));
  assert_ok(hetinv_measurements_create(s->ctx, &s->set));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->ortho, s->steady, NULL));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->transmit, s->steady, NULL));
  assert_int_equal(hetinv_measurements_value_count(s->set), SMALL_SCENE_VALUES);
  assert_ok(hetinv_param_map_create_identity(s->medium, HETINV_FREE_ALL, &s->map));
  s->k = hetinv_param_map_size(s->map);
  assert_ok(hetinv_estimator_create(s->ctx, &s->est));
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, 1000));
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_BATCHES, batches));
}

void small_scene_release(small_scene_t *s) {
  hetinv_estimator_destroy(&s->est);
  hetinv_param_map_destroy(&s->map);
  hetinv_measurements_destroy(&s->set);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_sensor_destroy(&s->ortho);
  hetinv_sensor_destroy(&s->transmit);
  hetinv_emitter_destroy(&s->beam);
  hetinv_medium_destroy(&s->medium);
  hetinv_context_destroy(&s->ctx);
}
