/* The fiber probe (lib/sensors/fiber.c): its arguments, and what it scores
 * against the hemispherical detector on the same photons, bit for bit:
 * - a disk over the whole face with NA ≥ η_out is that face's hemispherical
 *   detector (values, errors, ballistic part and gradient, on every face);
 * - an oblique pencil beam through a non-scattering slab leaves at one
 *   point and one angle θ_e, with η_out·sin θ_e equal to the beam's own
 *   η_out·sin of its incidence (parallel faces), so a small fiber there is
 *   a small hemispherical rectangle when its NA is just above that, and
 *   sees nothing when just below or when moved off the point. η_out ≠ 1
 *   and η ≠ η_out, so an NA compared with the inside angle or with sin θ
 *   alone fails.
 * The closed forms of the accepted power are in
 * tests/validation/test_fiber.c. */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "test_support.h"

#include "estimator/set_hash.h"

enum { VOXELS = 8 };

typedef struct fixture {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_pathlength_t *bins;
  hetinv_param_map_t *map;
  hetinv_estimator_t *est;
} fixture_t;

/* A scattering 2 × 2 × 2 box (one odd voxel), η = 1.4 inside, 1.33 outside. */
static void fixture_init(fixture_t *f, double sigma_s) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 2;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  assert_ok(hetinv_medium_create(f->ctx, (double[]){0, 0, 0}, (double[]){2, 2, 2}, (int32_t[]){2, 2, 2},
                                 &f->medium));
  assert_ok(hetinv_medium_fill(f->medium, 0.3, sigma_s, 0.5));
  if (sigma_s > 0.0) assert_ok(hetinv_medium_set_voxel(f->medium, 1, 0, 1, 0.8, 4.0, 0.2));
  assert_ok(hetinv_medium_set_ior(f->medium, 1.4, 1.33));
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

typedef struct run {
  double values[4], errors[4], ballistic[4], grad[3 * VOXELS];
} run_t;

/* Render (values, errors, ballistic part) and gradient (a cotangent per
 * value) of one row of the beam. */
static void run(fixture_t *f, const hetinv_emitter_t *e, hetinv_sensor_t *s, run_t *out) {
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(f->ctx, &set));
  assert_ok(hetinv_measurements_add(set, e, s, f->bins, NULL));
  assert_int_equal(hetinv_measurements_value_count(set), 4);
  assert_ok(hetinv_estimator_render(f->est, f->medium, set, out->values, out->errors, out->ballistic, 4));
  const double cot[4] = {1.0, 0.5, 0.25, 2.0};
  assert_ok(hetinv_estimator_gradient(f->est, f->medium, set, cot, 4, f->map, out->grad, NULL, 3 * VOXELS));
  hetinv_measurements_destroy(&set);
}

static void assert_same_run(const run_t *a, const run_t *b) {
  assert_memory_equal(a->values, b->values, sizeof a->values);
  assert_memory_equal(a->errors, b->errors, sizeof a->errors);
  assert_memory_equal(a->ballistic, b->ballistic, sizeof a->ballistic);
  assert_memory_equal(a->grad, b->grad, sizeof a->grad);
}

static bool last_error_names(const char *what) {
  const char *m = hetinv_context_last_error_message(NULL);
  if (strstr(m, "hetinv_sensor_create_fiber: ") == m && strstr(m, what) != NULL) return true;
  print_error("message \"%s\" does not name %s\n", m, what);
  return false;
}

static void bad_arguments_are_refused_with_their_names(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, 2.0);
  hetinv_sensor_t *s = NULL;
  const double on_face[2] = {1.0, 1.0};
  assert_int_equal(hetinv_sensor_create_fiber(f.medium, HETINV_FACE_Z_MAX, on_face, 0.1, 0.22, NULL),
                   HETINV_ERROR_NULL_ARGUMENT);
  assert_int_equal(hetinv_sensor_create_fiber(NULL, HETINV_FACE_Z_MAX, on_face, 0.1, 0.22, &s),
                   HETINV_ERROR_NULL_ARGUMENT);
  assert_int_equal(hetinv_sensor_create_fiber(f.medium, HETINV_FACE_Z_MAX, NULL, 0.1, 0.22, &s),
                   HETINV_ERROR_NULL_ARGUMENT);
  assert_true(last_error_names("centre"));
  assert_int_equal(hetinv_sensor_create_fiber(f.medium, 6, on_face, 0.1, 0.22, &s), HETINV_ERROR_OUT_OF_RANGE);
  const double radii[] = {0.0, -0.1, (double)NAN, (double)INFINITY, 1e-200};
  for (size_t i = 0; i < sizeof radii / sizeof radii[0]; ++i) {
    assert_int_equal(hetinv_sensor_create_fiber(f.medium, HETINV_FACE_Z_MAX, on_face, radii[i], 0.22, &s),
                     HETINV_ERROR_INVALID_ARGUMENT);
    assert_true(last_error_names("radius"));
  }
  const double apertures[] = {0.0, -0.22, (double)NAN, (double)INFINITY};
  for (size_t i = 0; i < sizeof apertures / sizeof apertures[0]; ++i) {
    assert_int_equal(hetinv_sensor_create_fiber(f.medium, HETINV_FACE_Z_MAX, on_face, 0.1, apertures[i], &s),
                     HETINV_ERROR_INVALID_ARGUMENT);
    assert_true(last_error_names("numerical_aperture"));
  }
  const double off_face[][2] = {{-0.01, 1.0}, {1.0, 2.01}, {(double)NAN, 1.0}};
  for (size_t i = 0; i < sizeof off_face / sizeof off_face[0]; ++i) {
    assert_int_equal(hetinv_sensor_create_fiber(f.medium, HETINV_FACE_X_MIN, off_face[i], 0.1, 0.22, &s),
                     HETINV_ERROR_INVALID_ARGUMENT);
    assert_true(last_error_names("centre["));
    assert_null(s);
  }
  /* On the face's edge, and a disk reaching beyond the face, are fine. */
  assert_ok(hetinv_sensor_create_fiber(f.medium, HETINV_FACE_X_MIN, (double[]){0.0, 2.0}, 5.0, 2.0, &s));
  assert_int_equal(hetinv_sensor_pixel_count(s), 1);
  int32_t w = 0, h = 0;
  assert_ok(hetinv_sensor_get_size(s, &w, &h));
  assert_true(w == 1 && h == 1);
  hetinv_sensor_destroy(&s);
  fixture_release(&f);
}

static void a_whole_face_fiber_accepting_every_direction_is_the_hemispherical_detector(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, 2.0);
  /* The face is 2 × 2 around (1, 1): a radius of 1.5 covers it. NA = η_out
   * and above accept every direction. */
  const double apertures[2] = {1.33, 3.0};
  for (int face = HETINV_FACE_X_MIN; face <= HETINV_FACE_Z_MAX; ++face) {
    hetinv_sensor_t *hemi = NULL;
    assert_ok(hetinv_sensor_create_hemispherical(f.medium, (hetinv_face_t)face, NULL, NULL, &hemi));
    run_t r_hemi;
    run(&f, f.beam, hemi, &r_hemi);
    for (int a = 0; a < 2; ++a) {
      hetinv_sensor_t *fiber = NULL;
      assert_ok(hetinv_sensor_create_fiber(f.medium, (hetinv_face_t)face, (double[]){1.0, 1.0}, 1.5,
                                           apertures[a], &fiber));
      run_t r_fiber;
      run(&f, f.beam, fiber, &r_fiber);
      assert_same_run(&r_fiber, &r_hemi);
      hetinv_sensor_destroy(&fiber);
    }
    if (face == HETINV_FACE_Z_MAX) assert_true(r_hemi.values[0] + r_hemi.values[1] > 0.0);
    hetinv_sensor_destroy(&hemi);
  }
  fixture_release(&f);
}

static void an_oblique_beam_is_accepted_only_within_the_aperture_and_the_disk(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, 0.0);
  /* Beam from outside at sin θ_e = 0.6 entering z_min at (0.3, 0.9): it
   * leaves z_max (2 deep) at 0.3 + 2·tan θ_i = 1.69 along x, sin θ_i = 1.33·0.6/1.4,
   * at θ_e again outside, so η_out·sin θ_e = 0.798. */
  const double dir[3] = {0.6, 0.0, 0.8}, entry[2] = {0.3, 0.9};
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(f.medium, (double[]){entry[0] - 0.6, entry[1], -0.8}, dir, &beam));
  const double sin_i = 1.33 * 0.6 / 1.4, tan_i = sin_i / sqrt(1.0 - sin_i * sin_i);
  const double exit_uv[2] = {entry[0] + 2.0 * tan_i, entry[1]}, na_beam = 1.33 * 0.6, r = 0.05;
  hetinv_sensor_t *rect = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(f.medium, HETINV_FACE_Z_MAX,
                                               (double[]){exit_uv[0] - r, exit_uv[1] - r},
                                               (double[]){exit_uv[0] + r, exit_uv[1] + r}, &rect));
  run_t r_rect;
  run(&f, beam, rect, &r_rect);
  assert_true(r_rect.values[0] + r_rect.values[1] > 0.1); /* the first pass, e^{-0.3·2/cos θ_i} · T² */
  const run_t nothing = {{0}, {0}, {0}, {0}};
  struct {
    double centre[2], na;
    const run_t *expected;
  } cases[] = {
      {{exit_uv[0], exit_uv[1]}, na_beam * (1.0 + 1e-9), &r_rect},
      {{exit_uv[0], exit_uv[1]}, na_beam * (1.0 - 1e-9), &nothing},
      {{exit_uv[0] + 1.01 * r, exit_uv[1]}, 1.33, &nothing},
      {{exit_uv[0], exit_uv[1] - 1.01 * r}, 1.33, &nothing},
      {{exit_uv[0] + 0.99 * r, exit_uv[1]}, na_beam * (1.0 + 1e-9), &r_rect},
      /* the inside angle's sin θ_i·η would be 0.798 too; sin θ_e alone 0.6 */
      {{exit_uv[0], exit_uv[1]}, 0.61, &nothing},
  };
  for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
    hetinv_sensor_t *fiber = NULL;
    assert_ok(hetinv_sensor_create_fiber(f.medium, HETINV_FACE_Z_MAX, cases[c].centre, r, cases[c].na, &fiber));
    run_t r_fiber;
    run(&f, beam, fiber, &r_fiber);
    if (memcmp(r_fiber.values, cases[c].expected->values, sizeof r_fiber.values) != 0) {
      print_error("case %zu: fiber %g %g %g %g\n", c, r_fiber.values[0], r_fiber.values[1], r_fiber.values[2],
                  r_fiber.values[3]);
    }
    assert_same_run(&r_fiber, cases[c].expected);
    hetinv_sensor_destroy(&fiber);
  }
  hetinv_sensor_destroy(&rect);
  hetinv_emitter_destroy(&beam);
  fixture_release(&f);
}

/* An optimizer checkpoint compares the set's hash: every argument of a
 * fiber must change it, the same arguments must not. */
static void every_argument_changes_the_set_hash(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, 2.0);
  const struct {
    hetinv_face_t face;
    double centre[2], radius, na;
  } variants[] = {{HETINV_FACE_Z_MAX, {1.0, 1.0}, 0.2, 0.22}, {HETINV_FACE_Z_MIN, {1.0, 1.0}, 0.2, 0.22},
                  {HETINV_FACE_Z_MAX, {1.1, 1.0}, 0.2, 0.22}, {HETINV_FACE_Z_MAX, {1.0, 1.1}, 0.2, 0.22},
                  {HETINV_FACE_Z_MAX, {1.0, 1.0}, 0.3, 0.22}, {HETINV_FACE_Z_MAX, {1.0, 1.0}, 0.2, 0.39}};
  enum { N = sizeof variants / sizeof variants[0] };
  uint64_t hashes[N + 1];
  for (int v = 0; v <= N; ++v) {
    int k = v < N ? v : 0; /* the last is the first again */
    hetinv_sensor_t *s = NULL;
    assert_ok(hetinv_sensor_create_fiber(f.medium, variants[k].face, variants[k].centre, variants[k].radius,
                                         variants[k].na, &s));
    hetinv_measurements_t *set = NULL;
    assert_ok(hetinv_measurements_create(f.ctx, &set));
    assert_ok(hetinv_measurements_add(set, f.beam, s, f.bins, NULL));
    hashes[v] = hv_set_geometry_hash(set);
    hetinv_measurements_destroy(&set);
    hetinv_sensor_destroy(&s);
  }
  for (int a = 0; a < N; ++a) {
    for (int b = a + 1; b < N; ++b) assert_true(hashes[a] != hashes[b]);
  }
  assert_true(hashes[N] == hashes[0]);
  fixture_release(&f);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(bad_arguments_are_refused_with_their_names),
      cmocka_unit_test(a_whole_face_fiber_accepting_every_direction_is_the_hemispherical_detector),
      cmocka_unit_test(an_oblique_beam_is_accepted_only_within_the_aperture_and_the_disk),
      cmocka_unit_test(every_argument_changes_the_set_hash),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
