/* A sensor kind is one file: its data, its create function and its hooks
 * (transport/sensor_kind.h), registered by setting itself on the sensors it
 * creates (hv_sensor_new). This test is such a file for a toy kind, an
 * "exit counter" that scores every photon leaving through its face, and
 * checks that the photon loop, the plan and both passes handle it with no
 * other change: its render and gradient equal, bit for bit, those of the
 * hemispherical sensor over the same face (which scores the same at exits),
 * and a kind without hooks scores nothing. */
#include <math.h>
#include <string.h>

#include "test_support.h"

#include "medium/medium_internal.h"
#include "sampling/sensor_internal.h"
#include "transport/score.h"
#include "transport/sensor_kind.h"

enum { VOXELS = 8 };

static void count_exit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_sensor_target_t *t,
                       const hv_exit_t *out, hv_tally_t *tally) {
  (void)tr;
  if (t->sensor->face != out->face) return;
  hv_score(plan, t, tally, tally->values, tally->grad ? &tally->grad->path : NULL, 0, out->tau, out->w);
}

static const hv_sensor_kind_t EXIT_COUNTER = {.name = "exit counter", .at_exit = count_exit};
static const hv_sensor_kind_t BLIND = {.name = "blind"};

/* The toy kind's create function: the whole face as one pixel. */
static hetinv_sensor_t *create(const hetinv_medium_t *m, const hv_sensor_kind_t *kind, hetinv_face_t face) {
  hetinv_sensor_t *s = NULL;
  assert_ok(hv_sensor_new(m, kind, face, 0, &s));
  int au, av;
  hv_face_uv_axes(face, &au, &av);
  s->origin[0] = s->geo.lo[au];
  s->origin[1] = s->geo.lo[av];
  s->pixel_size[0] = s->geo.hi[au] - s->geo.lo[au];
  s->pixel_size[1] = s->geo.hi[av] - s->geo.lo[av];
  s->width = s->height = 1;
  return s;
}

typedef struct fixture {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_pathlength_t *bins;
  hetinv_param_map_t *map;
  hetinv_estimator_t *est;
} fixture_t;

static void fixture_init(fixture_t *f) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 2;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  assert_ok(hetinv_medium_create(f->ctx, (double[]){0, 0, 0}, (double[]){2, 2, 2}, (int32_t[]){2, 2, 2},
                                 &f->medium));
  assert_ok(hetinv_medium_fill(f->medium, 0.3, 2.0, 0.5));
  assert_ok(hetinv_medium_set_voxel(f->medium, 1, 0, 1, 0.8, 4.0, 0.2));
  assert_ok(hetinv_medium_set_ior(f->medium, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(f->medium));
  assert_ok(hetinv_emitter_create_ideal(f->medium, (double[]){0.7, 1.2, -1}, (double[]){0, 0, 1}, &f->beam));
  double centres[4] = {1, 3, 5, 7};
  assert_ok(hetinv_pathlength_create_bins(f->ctx, HETINV_WINDOW_BOX, 4, centres, 2.0, &f->bins));
  assert_ok(hetinv_param_map_create_identity(f->medium, HETINV_FREE_ALL, &f->map));
  assert_ok(hetinv_estimator_create(f->ctx, &f->est));
  assert_ok(hetinv_estimator_set_param(f->est, HETINV_ESTIMATOR_PHOTONS, 4000));
}

static void fixture_release(fixture_t *f) {
  hetinv_estimator_destroy(&f->est);
  hetinv_param_map_destroy(&f->map);
  hetinv_pathlength_destroy(&f->bins);
  hetinv_emitter_destroy(&f->beam);
  hetinv_medium_destroy(&f->medium);
  hetinv_context_destroy(&f->ctx);
}

/* Render and gradient (cotangent 1 for every value) of one row. */
static void run(fixture_t *f, hetinv_sensor_t *s, double values[4], double grad[3 * VOXELS]) {
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(f->ctx, &set));
  assert_ok(hetinv_measurements_add(set, f->beam, s, f->bins, NULL));
  assert_int_equal(hetinv_measurements_value_count(set), 4);
  assert_ok(hetinv_estimator_render(f->est, f->medium, set, values, NULL, NULL, 4));
  const double cot[4] = {1.0, 0.5, 0.25, 2.0};
  assert_ok(hetinv_estimator_gradient(f->est, f->medium, set, cot, 4, f->map, grad, NULL, 3 * VOXELS));
  hetinv_measurements_destroy(&set);
}

static void a_kind_in_one_file_scores_like_its_builtin_twin(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f);
  for (int face = HETINV_FACE_Z_MIN; face <= HETINV_FACE_Z_MAX; ++face) {
    hetinv_sensor_t *toy = create(f.medium, &EXIT_COUNTER, (hetinv_face_t)face), *hemi = NULL;
    assert_ok(hetinv_sensor_create_hemispherical(f.medium, (hetinv_face_t)face, NULL, NULL, &hemi));
    double v_toy[4], v_hemi[4], g_toy[3 * VOXELS], g_hemi[3 * VOXELS];
    run(&f, toy, v_toy, g_toy);
    run(&f, hemi, v_hemi, g_hemi);
    assert_memory_equal(v_toy, v_hemi, sizeof v_toy);
    assert_memory_equal(g_toy, g_hemi, sizeof g_toy);
    assert_true(v_toy[0] + v_toy[1] + v_toy[2] + v_toy[3] > 0.0);
    hetinv_sensor_destroy(&toy);
    hetinv_sensor_destroy(&hemi);
  }
  fixture_release(&f);
}

static void a_kind_without_hooks_scores_nothing(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f);
  hetinv_sensor_t *blind = create(f.medium, &BLIND, HETINV_FACE_Z_MAX);
  double v[4], g[3 * VOXELS];
  run(&f, blind, v, g);
  for (int i = 0; i < 4; ++i) assert_true(v[i] == 0.0);
  for (int i = 0; i < 3 * VOXELS; ++i) assert_true(g[i] == 0.0);
  hetinv_sensor_destroy(&blind);
  fixture_release(&f);
}

/* A camera along a face normal reaches only the prism over its pixels
 * (its reach hook): the photon loop then skips the connection hook at every
 * other vertex. Skipping must change nothing: the render and gradient equal,
 * bit for bit, those of the same camera with the hook called everywhere,
 * and a point just outside the box lies on no pixel. */
static void a_reach_box_skips_only_vertices_that_cannot_score(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f);
  /* Two 0.3 × 0.2 pixels off the face's centre, on z = 2, looking along +z. */
  hetinv_sensor_t *cam = NULL;
  assert_ok(hetinv_sensor_create_orthographic(f.medium, HETINV_FACE_Z_MAX, (double[]){0, 0, 1},
                                              (double[]){0.5, 1.1}, (double[]){0.3, 0.2}, 2, 1, &cam));
  double lo[3], hi[3];
  for (int a = 0; a < 3; ++a) {
    lo[a] = -(double)INFINITY;
    hi[a] = (double)INFINITY;
  }
  assert_non_null(cam->kind->reach);
  cam->kind->reach(cam, lo, hi);
  assert_true(lo[0] <= 0.5 && hi[0] >= 1.1 && lo[1] <= 1.1 && hi[1] >= 1.3);
  assert_true(lo[0] > 0.49 && hi[0] < 1.11 && lo[1] > 1.09 && hi[1] < 1.31); /* the box is the prism */
  assert_true(isinf(lo[2]) && isinf(hi[2]));
  for (int a = 0; a < 2; ++a) {
    double p[3] = {0.8, 1.2, 1.0};
    p[a] = nextafter(lo[a], -(double)INFINITY);
    assert_true(hv_sensor_pixel_at(cam, p) < 0);
    p[a] = nextafter(hi[a], (double)INFINITY);
    assert_true(hv_sensor_pixel_at(cam, p) < 0);
  }
  /* run() expects 4 values: 2 pixels × 2 bins. */
  double centres[2] = {1.5, 4.5};
  hetinv_pathlength_destroy(&f.bins);
  assert_ok(hetinv_pathlength_create_bins(f.ctx, HETINV_WINDOW_BOX, 2, centres, 3.0, &f.bins));
  double v_box[4], v_all[4], g_box[3 * VOXELS], g_all[3 * VOXELS];
  run(&f, cam, v_box, g_box);
  const hv_sensor_kind_t *kind = cam->kind;
  hv_sensor_kind_t everywhere = *kind;
  everywhere.reach = NULL;
  cam->kind = &everywhere;
  run(&f, cam, v_all, g_all);
  cam->kind = kind;
  assert_memory_equal(v_box, v_all, sizeof v_box);
  assert_memory_equal(g_box, g_all, sizeof g_box);
  assert_true(v_box[0] > 0.0 && v_box[1] > 0.0);
  hetinv_sensor_destroy(&cam);
  fixture_release(&f);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(a_kind_in_one_file_scores_like_its_builtin_twin),
      cmocka_unit_test(a_kind_without_hooks_scores_nothing),
      cmocka_unit_test(a_reach_box_skips_only_vertices_that_cannot_score),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
