/* Sampling functions: emitters (W_i), sensors (W_o) and pathlength windows
 * (W_τ); every validation path of their create functions. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

/* A box with a different extent along each axis, so that messages naming a
 * face's range tell the axes apart: x ∈ [0, 10], y ∈ [0, 20], z ∈ [0, 30]. */
static const double box_min[3] = {0, 0, 0};
static const double box_max[3] = {10, 20, 30};

#define NaN ((double)NAN)
#define Inf ((double)INFINITY)

/* Tangents of 60° and 80°: a direction (tan θ, 0, 1) is θ from the z axis. */
static const double tan60 = 1.7320508075688772;
static const double tan80 = 5.6712818196177066;

static hetinv_medium_t *make_medium(hetinv_context_t *ctx, double eta, double eta_out) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, box_min, box_max, (int32_t[]){2, 2, 2}, &m));
  assert_ok(hetinv_medium_set_ior(m, eta, eta_out));
  return m;
}

/* Sentinel a failing create must overwrite with NULL. */
static hetinv_emitter_t *emitter_sentinel(void) { return (hetinv_emitter_t *)ht_sentinel(); }
static hetinv_sensor_t *sensor_sentinel(void) { return (hetinv_sensor_t *)ht_sentinel(); }

/* ------------------------------------------------------------------------ */
/* Ideal emitters */

static void ideal_emitter_is_created_for_a_beam_entering_the_box(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.4, 1.0);
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, 3}, &e));
  assert_non_null(e);
  hetinv_emitter_destroy(&e);
  assert_null(e);
  /* Oblique, through a side face, from far away. */
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){-100, 10, 15}, (double[]){1, 0.01, -0.02}, &e));
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_accepts_an_origin_on_the_boundary(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 10, 0}, (double[]){0, 0, 1}, &e));
  hetinv_emitter_destroy(&e);
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){10, 3, 4}, (double[]){-1, 1, 1}, &e));
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_does_not_need_a_committed_medium(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = NULL;
  assert_false(hetinv_medium_is_committed(m));
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, 1}, &e));
  hetinv_emitter_destroy(&e);
  assert_ok(hetinv_medium_commit(m));
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, 1}, &e));
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_rejects_null_arguments(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double o[3] = {5, 10, -1}, d[3] = {0, 0, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_ideal(m, o, d, NULL));
  assert_message_contains("'out' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_ideal(NULL, o, d, &e));
  assert_message_contains("'medium' is NULL");
  assert_null(e);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_ideal(m, NULL, d, &e));
  assert_message_contains("hetinv_emitter_create_ideal: 'origin' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_ideal(m, o, NULL, &e));
  assert_message_contains("'direction' is NULL");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_rejects_a_zero_direction(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, 0}, &e));
  assert_message_contains("direction is (0, 0, 0); it must be finite and not zero");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_rejects_a_non_finite_direction(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){NaN, 0, 1}, &e));
  assert_message_contains("direction is (nan, 0, 1)");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, Inf}, &e));
  assert_message_contains("direction is (0, 0, inf)");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

/* Any finite non-zero vector is a direction, however long or short. */
static void ideal_emitter_accepts_very_long_or_short_directions(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, 1e-200}, &e));
  hetinv_emitter_destroy(&e);
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, 1e300}, &e));
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_rejects_a_non_finite_origin(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, -Inf, 15}, (double[]){0, 1, 0}, &e));
  assert_message_contains("origin is (5, -inf, 15); it must be finite");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_rejects_an_origin_inside_the_box(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, 10, 15}, (double[]){0, 0, 1}, &e));
  assert_message_contains("origin (5, 10, 15) is inside the box");
  assert_null(e);
  /* Just inside one face still counts as inside. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){9.999, 10, 15}, (double[]){-1, 0, 0}, &e));
  assert_message_contains("origin (9.999, 10, 15) is inside the box");
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_rejects_a_beam_that_misses_the_box(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  /* Pointing away from the box. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, 10, -1}, (double[]){0, 0, -1}, &e));
  assert_message_contains("the beam from (5, 10, -1) along (0, 0, -1) misses the box");
  assert_null(e);
  /* Parallel to the box, beside it. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){11, 10, -1}, (double[]){0, 0, 1}, &e));
  assert_message_contains("misses the box [0, 10] x [0, 20] x [0, 30]");
  /* Leaving the box from its boundary. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, 10, 0}, (double[]){0, 0.5, -1}, &e));
  assert_message_contains("misses the box");
  hetinv_medium_destroy(&m);
}

static void ideal_emitter_rejects_a_beam_that_only_grazes_an_edge(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  /* Diagonal in the xy plane, touching the edge x = 0, y = 0 at z = 15. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){-1, 1, 15}, (double[]){1, -1, 0}, &e));
  assert_message_contains("misses the box");
  assert_null(e);
  /* Touching only the corner (10, 20, 30). */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){11, 21, 29}, (double[]){-1, -1, 1}, &e));
  assert_message_contains("misses the box");
  hetinv_medium_destroy(&m);
}

/* A ray in the plane of a face only grazes the box: it never enters its
 * interior, whether it starts on the face or comes from outside through an
 * edge. */
static void ideal_emitter_rejects_a_beam_sliding_along_a_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  /* In the plane y = 0 of face Y_MIN, starting on the face. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_ideal(m, (double[]){5, 0, 15}, (double[]){1, 0, 0}, &e));
  assert_message_contains("misses the box");
  assert_null(e);
  /* The same line from outside, reaching the face through the edge x = 0, y = 0. */
  e = emitter_sentinel();
  hetinv_result_t r = hetinv_emitter_create_ideal(m, (double[]){-1, 0, 15}, (double[]){1, 0, 0}, &e);
  if (r == HETINV_SUCCESS) {
    hetinv_emitter_destroy(&e);
    hetinv_medium_destroy(&m);
    print_error("a beam lying in the plane of face Y_MIN, from (-1, 0, 15) along +x, was accepted\n");
    fail();
  }
  assert_int_equal(r, HETINV_ERROR_INVALID_ARGUMENT);
  assert_message_contains("the beam from (-1, 0, 15) along (1, 0, 0) misses the box");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* Combinations of ideal sources */

static void combination_emitter_is_created_from_valid_sources(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.3, 1);
  const double origins[6] = {5, 10, -1, -1, 10, 15};
  const double directions[6] = {0, 0, 1, 1, 0, 0};
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_combination(m, 2, origins, directions, (double[]){0.25, 0}, &e));
  assert_non_null(e);
  hetinv_emitter_destroy(&e);
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void combination_emitter_rejects_null_arguments(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double o[3] = {5, 10, -1}, d[3] = {0, 0, 1}, w[1] = {1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_combination(m, 1, o, d, w, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_combination(NULL, 1, o, d, w, &e));
  assert_null(e);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_combination(m, 1, NULL, d, w, &e));
  assert_message_contains("'origins' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_combination(m, 1, o, NULL, w, &e));
  assert_message_contains("'directions' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_combination(m, 1, o, d, NULL, &e));
  assert_message_contains("'weights' is NULL");
  hetinv_medium_destroy(&m);
}

static void combination_emitter_rejects_a_non_positive_count(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double o[3] = {5, 10, -1}, d[3] = {0, 0, 1}, w[1] = {1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_emitter_create_combination(m, 0, o, d, w, &e));
  assert_message_contains("count is 0; it must be > 0");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_emitter_create_combination(m, -4, o, d, w, &e));
  assert_message_contains("count is -4");
  hetinv_medium_destroy(&m);
}

static void combination_emitter_names_a_source_with_a_zero_direction(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double origins[6] = {5, 10, -1, 5, 10, -1};
  const double directions[6] = {0, 0, 1, 0, 0, 0};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, 2, origins, directions, (double[]){1, 1}, &e));
  assert_message_contains("direction of source 1 is (0, 0, 0)");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void combination_emitter_names_a_source_inside_the_box(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double origins[9] = {5, 10, -1, 5, 10, 31, 5, 10, 15};
  const double directions[9] = {0, 0, 1, 0, 0, -1, 0, 0, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, 3, origins, directions, (double[]){1, 1, 1}, &e));
  assert_message_contains("origin of source 2 (5, 10, 15) is inside the box");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void combination_emitter_names_a_source_that_misses_the_box(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double origins[6] = {5, 10, -1, 5, 10, 31};
  const double directions[6] = {0, 0, 1, 0, 0, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, 2, origins, directions, (double[]){1, 1}, &e));
  assert_message_contains("the beam of source 1 from (5, 10, 31)");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void combination_emitter_names_a_source_with_a_non_finite_origin(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double origins[6] = {NaN, 10, -1, 5, 10, -1};
  const double directions[6] = {0, 0, 1, 0, 0, 1};
  hetinv_emitter_t *e = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, 2, origins, directions, (double[]){1, 1}, &e));
  assert_message_contains("origin of source 0 is (nan, 10, -1)");
  hetinv_medium_destroy(&m);
}

static void combination_emitter_rejects_negative_weights(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double origins[6] = {5, 10, -1, 5, 10, -1};
  const double directions[6] = {0, 0, 1, 0, 0, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, 2, origins, directions, (double[]){1, -0.5}, &e));
  assert_message_contains("weights[1] is -0.5; it must be finite and >= 0");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, 2, origins, directions, (double[]){Inf, 1}, &e));
  assert_message_contains("weights[0] is inf");
  hetinv_medium_destroy(&m);
}

static void combination_emitter_rejects_all_zero_weights(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double origins[6] = {5, 10, -1, 5, 10, -1};
  const double directions[6] = {0, 0, 1, 0, 0, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_combination(m, 2, origins, directions, (double[]){0, 0}, &e));
  assert_message_contains("the 2 values of weights sum to 0");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* Area emitters */

static void area_emitter_is_created_uniform_or_patterned(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.4, 1);
  hetinv_emitter_t *e = NULL;
  /* Face X_MIN: coordinates (y, z) ∈ [0, 20] × [0, 30]. */
  assert_ok(hetinv_emitter_create_area(m, HETINV_FACE_X_MIN, (double[]){1, 0.2, 0},
                                       (double[]){0, 0}, (double[]){20, 30}, 1, 1, NULL, &e));
  assert_non_null(e);
  hetinv_emitter_destroy(&e);
  assert_null(e);
  const double pattern[6] = {0, 1, 2, 0, 0.5, 0};
  assert_ok(hetinv_emitter_create_area(m, HETINV_FACE_Z_MAX, (double[]){0, 0, -1},
                                       (double[]){2, 3}, (double[]){8, 19}, 3, 2, pattern, &e));
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_null_arguments(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, lo[2] = {0, 0}, hi[2] = {1, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 1, 1, NULL, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_emitter_create_area(NULL, HETINV_FACE_Z_MIN, d, lo, hi, 1, 1, NULL, &e));
  assert_null(e);
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, NULL, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("'direction' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, NULL, hi, 1, 1, NULL, &e));
  assert_message_contains("'rect_min' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, NULL, 1, 1, NULL, &e));
  assert_message_contains("'rect_max' is NULL");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_an_unknown_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, lo[2] = {0, 0}, hi[2] = {1, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_emitter_create_area(m, 6, d, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("face is 6; it must be one of HETINV_FACE_X_MIN (0) .. HETINV_FACE_Z_MAX (5)");
  assert_null(e);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_emitter_create_area(m, -1, d, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("face is -1");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_a_zero_or_non_finite_direction(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double lo[2] = {0, 0}, hi[2] = {1, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, (double[]){0, 0, 0}, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("direction is (0, 0, 0)");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, (double[]){0, NaN, 1}, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("direction is (0, nan, 1)");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_a_direction_that_does_not_enter_its_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double lo[2] = {0, 0}, hi[2] = {1, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  /* Face Z_MIN is entered along +z. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, (double[]){0, 0, -1}, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("direction (0, 0, -1) does not point into face 4");
  assert_null(e);
  /* Along the face. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, (double[]){1, 1, 0}, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("direction (1, 1, 0) does not point into face 4");
  /* Face Y_MAX is entered along -y. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Y_MAX, (double[]){0, 1, 0}, lo, hi, 1, 1, NULL, &e));
  assert_message_contains("does not point into face 3");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_a_rectangle_outside_its_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, -1, 0};
  hetinv_emitter_t *e = emitter_sentinel();
  /* Face Y_MAX: coordinates (x, z) ∈ [0, 10] × [0, 30]. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Y_MAX, d, (double[]){-1, 0},
                                           (double[]){5, 5}, 1, 1, NULL, &e));
  assert_message_contains("rectangle coordinate x is [-1, 5]; it must lie within the face's [0, 10] with min < max");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Y_MAX, d, (double[]){0, 0},
                                           (double[]){5, 30.5}, 1, 1, NULL, &e));
  assert_message_contains("rectangle coordinate z is [0, 30.5]; it must lie within the face's [0, 30]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Y_MAX, d, (double[]){0, NaN},
                                           (double[]){5, 5}, 1, 1, NULL, &e));
  assert_message_contains("rectangle coordinate z is [nan, 5]");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_an_empty_rectangle(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {1, 0, 0};
  hetinv_emitter_t *e = emitter_sentinel();
  /* Face X_MIN: coordinates (y, z). */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_X_MIN, d, (double[]){4, 2},
                                           (double[]){4, 6}, 1, 1, NULL, &e));
  assert_message_contains("rectangle coordinate y is [4, 4]");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_X_MIN, d, (double[]){1, 7},
                                           (double[]){4, 6}, 1, 1, NULL, &e));
  assert_message_contains("rectangle coordinate z is [7, 6]");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_non_positive_pattern_sizes(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, lo[2] = {0, 0}, hi[2] = {1, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 0, 3, NULL, &e));
  assert_message_contains("the pattern is 0 x 3");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 2, -1, NULL, &e));
  assert_message_contains("the pattern is 2 x -1");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 65536, 65536, NULL, &e));
  assert_message_contains("the pattern is 65536 x 65536");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_negative_pattern_weights(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, lo[2] = {0, 0}, hi[2] = {1, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 2, 2,
                                           (double[]){1, 0, -0.25, 1}, &e));
  assert_message_contains("pattern[2] is -0.25; it must be finite and >= 0");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 2, 2,
                                           (double[]){1, NaN, 0, 1}, &e));
  assert_message_contains("pattern[1] is nan");
  hetinv_medium_destroy(&m);
}

static void area_emitter_rejects_an_all_zero_pattern(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, lo[2] = {0, 0}, hi[2] = {1, 1};
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_area(m, HETINV_FACE_Z_MIN, d, lo, hi, 3, 1,
                                           (double[]){0, 0, 0}, &e));
  assert_message_contains("the 3 values of pattern sum to 0");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* Diffuse point emitters */

static void diffuse_emitter_is_created_on_a_face_and_its_edges(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.4, 1);
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MIN, (double[]){5, 10}, &e));
  assert_non_null(e);
  hetinv_emitter_destroy(&e);
  assert_null(e);
  /* A corner of face X_MAX, coordinates (y, z). */
  assert_ok(hetinv_emitter_create_diffuse(m, HETINV_FACE_X_MAX, (double[]){20, 30}, &e));
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
}

static void diffuse_emitter_rejects_null_arguments(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MIN, (double[]){1, 1}, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_emitter_create_diffuse(NULL, HETINV_FACE_Z_MIN, (double[]){1, 1}, &e));
  assert_null(e);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MIN, NULL, &e));
  assert_message_contains("'point' is NULL");
  hetinv_medium_destroy(&m);
}

static void diffuse_emitter_rejects_an_unknown_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_emitter_create_diffuse(m, 17, (double[]){1, 1}, &e));
  assert_message_contains("face is 17");
  assert_null(e);
  hetinv_medium_destroy(&m);
}

static void diffuse_emitter_rejects_a_point_off_its_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_emitter_t *e = emitter_sentinel();
  /* Face Y_MIN: coordinates (x, z) ∈ [0, 10] × [0, 30]. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_diffuse(m, HETINV_FACE_Y_MIN, (double[]){11, 5}, &e));
  assert_message_contains("point coordinate x is [11, 11]; it must lie within the face's [0, 10]");
  assert_null(e);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_diffuse(m, HETINV_FACE_Y_MIN, (double[]){5, -0.5}, &e));
  assert_message_contains("point coordinate z is [-0.5, -0.5]; it must lie within the face's [0, 30]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_emitter_create_diffuse(m, HETINV_FACE_Y_MIN, (double[]){Inf, 5}, &e));
  assert_message_contains("point coordinate x is [inf, inf]");
  hetinv_medium_destroy(&m);
}

static void emitter_destroy_accepts_null_and_clears_the_handle(void **state) {
  hetinv_emitter_destroy(NULL);
  hetinv_emitter_t *e = NULL;
  hetinv_emitter_destroy(&e);
  assert_null(e);
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  assert_ok(hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MIN, (double[]){1, 1}, &e));
  hetinv_emitter_destroy(&e);
  assert_null(e);
  hetinv_emitter_destroy(&e); /* twice: the cleared handle is a no-op */
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* Orthographic sensors */

static void orthographic_sensor_reports_its_pixel_grid(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.4, 1);
  hetinv_sensor_t *s = NULL;
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0, 0, 1},
                                              (double[]){-1, 2}, (double[]){0.5, 2}, 4, 3, &s));
  assert_non_null(s);
  assert_int_equal(hetinv_sensor_pixel_count(s), 12);
  int32_t w = 0, h = 0;
  assert_ok(hetinv_sensor_get_size(s, &w, &h));
  assert_int_equal(w, 4);
  assert_int_equal(h, 3);
  assert_ok(hetinv_sensor_get_size(s, NULL, &h));
  assert_ok(hetinv_sensor_get_size(s, &w, NULL));
  hetinv_sensor_destroy(&s);
  assert_null(s);
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_accepts_an_oblique_direction(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.4, 1);
  hetinv_sensor_t *s = NULL;
  /* 80° from the normal of face X_MIN: light leaving a denser medium can. */
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_X_MIN, (double[]){-1, tan80, 0},
                                              (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  hetinv_sensor_destroy(&s);
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_null_arguments(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, o[2] = {0, 0}, px[2] = {1, 1};
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, 1, 1, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_sensor_create_orthographic(NULL, HETINV_FACE_Z_MAX, d, o, px, 1, 1, &s));
  assert_null(s);
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, NULL, o, px, 1, 1, &s));
  assert_message_contains("'direction' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, NULL, px, 1, 1, &s));
  assert_message_contains("'origin' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, NULL, 1, 1, &s));
  assert_message_contains("'pixel_size' is NULL");
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_an_unknown_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_OUT_OF_RANGE,
                hetinv_sensor_create_orthographic(m, 6, (double[]){0, 0, 1}, (double[]){0, 0},
                                                  (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("face is 6");
  assert_null(s);
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_a_direction_into_the_medium(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0.1, 0, -1},
                                                  (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("direction (0.1, 0, -1) points into the medium through face 5");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_X_MIN, (double[]){1, 0, 0},
                                                  (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("points into the medium through face 0");
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_a_direction_along_its_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Y_MIN, (double[]){1, 0, 1},
                                                  (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("direction (1, 0, 1) points along face 2");
  assert_null(s);
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_a_zero_or_non_finite_direction(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0, 0, 0},
                                                  (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("direction is (0, 0, 0)");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0, 0, Inf},
                                                  (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("direction is (0, 0, inf)");
  hetinv_medium_destroy(&m);
}

/* With η < η_out light leaving the medium bends toward the normal: outside,
 * it only travels within asin(η/η_out) of the normal. */
static void orthographic_sensor_rejects_a_direction_beyond_the_critical_angle(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.0, 1.5);
  hetinv_sensor_t *s = sensor_sentinel();
  /* 60° from the normal; the critical angle is 41.8°. */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){tan60, 0, 1},
                                                  (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("no light from inside leaves face 5");
  assert_message_contains("with eta 1 inside and 1.5 outside it lies beyond the critical angle");
  assert_null(s);
  /* 30° is within the cone. */
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){1, 0, tan60},
                                              (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  hetinv_sensor_destroy(&s);
  hetinv_medium_destroy(&m);
  /* The 60° direction is fine when the medium is the denser side. */
  m = make_medium(*state, 1.5, 1.0);
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){tan60, 0, 1},
                                              (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s));
  hetinv_sensor_destroy(&s);
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_non_positive_pixel_sizes(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, o[2] = {0, 0};
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, (double[]){1, 0}, 1, 1, &s));
  assert_message_contains("pixel_size[1] is 0; it must be finite and > 0");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, (double[]){-2, 1}, 1, 1, &s));
  assert_message_contains("pixel_size[0] is -2");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, (double[]){1, Inf}, 1, 1, &s));
  assert_message_contains("pixel_size[1] is inf");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, (double[]){NaN, 1}, 1, 1, &s));
  assert_message_contains("pixel_size[0] is nan");
  hetinv_medium_destroy(&m);
}

/* Values are per pixel area: an area (or its reciprocal) out of double's
 * normal range would make them inf or 0 without an error. */
static void orthographic_sensor_rejects_a_pixel_area_out_of_range(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, o[2] = {0, 0};
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_sensor_create_orthographic(
                                                   m, HETINV_FACE_Z_MAX, d, o, (double[]){1e-170, 1e-170}, 4, 4, &s));
  assert_message_contains("pixel_size is 1e-170 x 1e-170: its area 0 is not a normal double");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_sensor_create_orthographic(
                                                   m, HETINV_FACE_Z_MAX, d, o, (double[]){1e200, 1e200}, 1, 1, &s));
  assert_message_contains("its area inf");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_sensor_create_orthographic(
                                                   m, HETINV_FACE_Z_MAX, d, o, (double[]){1e308, 1e-300}, 2, 1, &s));
  assert_message_contains("origin[0] + width x pixel_size[0] is 0 + 2 x 1e+308, which is not finite");
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, (double[]){1e-150, 1e-150}, 1, 1, &s));
  hetinv_sensor_destroy(&s);
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_a_non_finite_origin(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0, 0, 1},
                                                  (double[]){0, -Inf}, (double[]){1, 1}, 1, 1, &s));
  assert_message_contains("origin[1] is -inf; it must be finite");
  assert_null(s);
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_non_positive_pixel_counts(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, o[2] = {0, 0}, px[2] = {1, 1};
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, 0, 5, &s));
  assert_message_contains("the sensor is 0 x 5 pixels; each must be > 0");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, 3, -1, &s));
  assert_message_contains("the sensor is 3 x -1 pixels");
  hetinv_medium_destroy(&m);
}

static void orthographic_sensor_rejects_overflowing_pixel_counts(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  const double d[3] = {0, 0, 1}, o[2] = {0, 0}, px[2] = {1, 1};
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, 65536, 32768, &s));
  assert_message_contains("65536 x 32768 pixels; at most HETINV_MAX_SENSOR_PIXELS (16777216)");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, INT32_MAX, 2, &s));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, 4097, 4096, &s));
  /* The bound itself is allowed (a sensor allocates no pixels). */
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, d, o, px, 4096, 4096, &s));
  assert_int_equal(hetinv_sensor_pixel_count(s), HETINV_MAX_SENSOR_PIXELS);
  hetinv_sensor_destroy(&s);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* Hemispherical detectors */

static void hemispherical_detector_has_one_value(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1.4, 1);
  hetinv_sensor_t *s = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &s));
  assert_int_equal(hetinv_sensor_pixel_count(s), 1);
  int32_t w = 0, h = 0;
  assert_ok(hetinv_sensor_get_size(s, &w, &h));
  assert_int_equal(w, 1);
  assert_int_equal(h, 1);
  hetinv_sensor_destroy(&s);
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_X_MAX, (double[]){1, 2},
                                               (double[]){3, 4}, &s));
  assert_int_equal(hetinv_sensor_pixel_count(s), 1);
  hetinv_sensor_destroy(&s);
  hetinv_medium_destroy(&m);
}

static void hemispherical_detector_rejects_null_arguments(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, NULL));
  assert_message_contains("'out' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_sensor_create_hemispherical(NULL, HETINV_FACE_Z_MIN, NULL, NULL, &s));
  assert_message_contains("'medium' is NULL");
  assert_null(s);
  hetinv_medium_destroy(&m);
}

static void hemispherical_detector_rejects_an_unknown_face(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_sensor_create_hemispherical(m, -3, NULL, NULL, &s));
  assert_message_contains("face is -3");
  assert_null(s);
  hetinv_medium_destroy(&m);
}

static void hemispherical_detector_rejects_a_rectangle_with_one_corner(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, (double[]){0, 0}, NULL, &s));
  assert_message_contains("rect_min is set and rect_max is NULL; give both or neither");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, (double[]){1, 1}, &s));
  assert_message_contains("rect_min is NULL and rect_max is set");
  hetinv_medium_destroy(&m);
}

static void hemispherical_detector_rejects_an_empty_or_non_finite_rectangle(void **state) {
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  hetinv_sensor_t *s = sensor_sentinel();
  /* Face Y_MIN: coordinates (x, z). */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_hemispherical(m, HETINV_FACE_Y_MIN, (double[]){5, 0},
                                                   (double[]){5, 1}, &s));
  assert_message_contains("the rectangle along x is [5, 5]; it must be finite with min < max");
  assert_null(s);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_hemispherical(m, HETINV_FACE_Y_MIN, (double[]){0, 3},
                                                   (double[]){1, 2}, &s));
  assert_message_contains("the rectangle along z is [3, 2]");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_sensor_create_hemispherical(m, HETINV_FACE_Y_MIN, (double[]){0, 0},
                                                   (double[]){NaN, 2}, &s));
  assert_message_contains("the rectangle along x is [0, nan]");
  hetinv_medium_destroy(&m);
}

static void sensor_queries_accept_null(void **state) {
  (void)state;
  assert_int_equal(hetinv_sensor_pixel_count(NULL), 0);
  int32_t w = 7, h = 7;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_sensor_get_size(NULL, &w, &h));
  assert_message_contains("'sensor' is NULL");
}

static void sensor_destroy_accepts_null_and_clears_the_handle(void **state) {
  hetinv_sensor_destroy(NULL);
  hetinv_sensor_t *s = NULL;
  hetinv_sensor_destroy(&s);
  hetinv_medium_t *m = make_medium(*state, 1, 1);
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &s));
  hetinv_sensor_destroy(&s);
  assert_null(s);
  hetinv_sensor_destroy(&s);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* Pathlength windows */

static void steady_pathlength_has_one_bin(void **state) {
  hetinv_pathlength_t *p = NULL;
  assert_ok(hetinv_pathlength_create_steady(*state, &p));
  assert_non_null(p);
  assert_int_equal(hetinv_pathlength_bin_count(p), 1);
  hetinv_pathlength_destroy(&p);
  assert_null(p);
}

static void steady_pathlength_rejects_null_arguments(void **state) {
  hetinv_pathlength_t *p = (hetinv_pathlength_t *)ht_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_pathlength_create_steady(*state, NULL));
  assert_message_contains("'out' is NULL");
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_pathlength_create_steady(NULL, &p));
  assert_message_contains("'ctx' is NULL");
  assert_null(p);
}

static void bins_report_their_count(void **state) {
  hetinv_pathlength_t *p = NULL;
  /* Unsorted, repeated and zero centres are allowed. */
  const double centres[5] = {30, 0, 10, 10, 2.5};
  assert_ok(hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 5, centres, 1.0, &p));
  assert_int_equal(hetinv_pathlength_bin_count(p), 5);
  hetinv_pathlength_destroy(&p);
  assert_ok(hetinv_pathlength_create_bins(*state, HETINV_WINDOW_GAUSSIAN, 1, centres, 1e-3, &p));
  assert_int_equal(hetinv_pathlength_bin_count(p), 1);
  hetinv_pathlength_destroy(&p);
}

static void bins_copy_their_centres(void **state) {
  double centres[2] = {1, 2};
  hetinv_pathlength_t *p = NULL;
  assert_ok(hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 2, centres, 1.0, &p));
  centres[0] = -1; /* the caller's array may change afterwards */
  assert_int_equal(hetinv_pathlength_bin_count(p), 2);
  hetinv_pathlength_destroy(&p);
}

static void bins_reject_null_arguments(void **state) {
  const double c[1] = {1};
  hetinv_pathlength_t *p = (hetinv_pathlength_t *)ht_sentinel();
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 1, c, 1, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_pathlength_create_bins(NULL, HETINV_WINDOW_BOX, 1, c, 1, &p));
  assert_message_contains("'ctx' is NULL");
  assert_null(p);
  assert_result(HETINV_ERROR_NULL_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 1, NULL, 1, &p));
  assert_message_contains("'centres' is NULL");
}

static void bins_reject_an_unknown_window(void **state) {
  const double c[1] = {1};
  hetinv_pathlength_t *p = (hetinv_pathlength_t *)ht_sentinel();
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_pathlength_create_bins(*state, 2, 1, c, 1, &p));
  assert_message_contains("window is 2; it must be HETINV_WINDOW_BOX (0) or HETINV_WINDOW_GAUSSIAN (1)");
  assert_null(p);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_pathlength_create_bins(*state, -1, 1, c, 1, &p));
  assert_message_contains("window is -1");
}

static void bins_reject_zero_bins(void **state) {
  const double c[1] = {1};
  hetinv_pathlength_t *p = (hetinv_pathlength_t *)ht_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 0, c, 1, &p));
  assert_message_contains("count is 0; it must be > 0");
  assert_null(p);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_GAUSSIAN, -2, c, 1, &p));
  assert_message_contains("count is -2");
}

static void bins_reject_a_non_positive_width(void **state) {
  const double c[1] = {1};
  hetinv_pathlength_t *p = (hetinv_pathlength_t *)ht_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 1, c, 0.0, &p));
  assert_message_contains("width is 0; it must be finite and > 0");
  assert_null(p);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_GAUSSIAN, 1, c, -0.5, &p));
  assert_message_contains("width is -0.5");
}

static void bins_reject_a_non_finite_width(void **state) {
  const double c[1] = {1};
  hetinv_pathlength_t *p = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 1, c, Inf, &p));
  assert_message_contains("width is inf");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_GAUSSIAN, 1, c, NaN, &p));
  assert_message_contains("width is nan");
  assert_null(p);
}

static void bins_reject_negative_centres(void **state) {
  const double c[3] = {1, 2, -0.5};
  hetinv_pathlength_t *p = (hetinv_pathlength_t *)ht_sentinel();
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 3, c, 1, &p));
  assert_message_contains("centres[2] is -0.5; it must be finite and >= 0");
  assert_null(p);
}

static void bins_reject_non_finite_centres(void **state) {
  const double c[2] = {Inf, 1};
  hetinv_pathlength_t *p = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_GAUSSIAN, 2, c, 1, &p));
  assert_message_contains("centres[0] is inf");
  const double d[2] = {1, NaN};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 2, d, 1, &p));
  assert_message_contains("centres[1] is nan");
  assert_null(p);
}

static void pathlength_destroy_accepts_null_and_clears_the_handle(void **state) {
  assert_int_equal(hetinv_pathlength_bin_count(NULL), 0);
  hetinv_pathlength_destroy(NULL);
  hetinv_pathlength_t *p = NULL;
  hetinv_pathlength_destroy(&p);
  assert_ok(hetinv_pathlength_create_bins(*state, HETINV_WINDOW_BOX, 1, (double[]){1}, 1, &p));
  hetinv_pathlength_destroy(&p);
  assert_null(p);
  hetinv_pathlength_destroy(&p);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(ideal_emitter_is_created_for_a_beam_entering_the_box),
      cmocka_unit_test(ideal_emitter_accepts_an_origin_on_the_boundary),
      cmocka_unit_test(ideal_emitter_does_not_need_a_committed_medium),
      cmocka_unit_test(ideal_emitter_rejects_null_arguments),
      cmocka_unit_test(ideal_emitter_rejects_a_zero_direction),
      cmocka_unit_test(ideal_emitter_rejects_a_non_finite_direction),
      cmocka_unit_test(ideal_emitter_accepts_very_long_or_short_directions),
      cmocka_unit_test(ideal_emitter_rejects_a_non_finite_origin),
      cmocka_unit_test(ideal_emitter_rejects_an_origin_inside_the_box),
      cmocka_unit_test(ideal_emitter_rejects_a_beam_that_misses_the_box),
      cmocka_unit_test(ideal_emitter_rejects_a_beam_that_only_grazes_an_edge),
      cmocka_unit_test(ideal_emitter_rejects_a_beam_sliding_along_a_face),
      cmocka_unit_test(combination_emitter_is_created_from_valid_sources),
      cmocka_unit_test(combination_emitter_rejects_null_arguments),
      cmocka_unit_test(combination_emitter_rejects_a_non_positive_count),
      cmocka_unit_test(combination_emitter_names_a_source_with_a_zero_direction),
      cmocka_unit_test(combination_emitter_names_a_source_inside_the_box),
      cmocka_unit_test(combination_emitter_names_a_source_that_misses_the_box),
      cmocka_unit_test(combination_emitter_names_a_source_with_a_non_finite_origin),
      cmocka_unit_test(combination_emitter_rejects_negative_weights),
      cmocka_unit_test(combination_emitter_rejects_all_zero_weights),
      cmocka_unit_test(area_emitter_is_created_uniform_or_patterned),
      cmocka_unit_test(area_emitter_rejects_null_arguments),
      cmocka_unit_test(area_emitter_rejects_an_unknown_face),
      cmocka_unit_test(area_emitter_rejects_a_zero_or_non_finite_direction),
      cmocka_unit_test(area_emitter_rejects_a_direction_that_does_not_enter_its_face),
      cmocka_unit_test(area_emitter_rejects_a_rectangle_outside_its_face),
      cmocka_unit_test(area_emitter_rejects_an_empty_rectangle),
      cmocka_unit_test(area_emitter_rejects_non_positive_pattern_sizes),
      cmocka_unit_test(area_emitter_rejects_negative_pattern_weights),
      cmocka_unit_test(area_emitter_rejects_an_all_zero_pattern),
      cmocka_unit_test(diffuse_emitter_is_created_on_a_face_and_its_edges),
      cmocka_unit_test(diffuse_emitter_rejects_null_arguments),
      cmocka_unit_test(diffuse_emitter_rejects_an_unknown_face),
      cmocka_unit_test(diffuse_emitter_rejects_a_point_off_its_face),
      cmocka_unit_test(emitter_destroy_accepts_null_and_clears_the_handle),
      cmocka_unit_test(orthographic_sensor_reports_its_pixel_grid),
      cmocka_unit_test(orthographic_sensor_accepts_an_oblique_direction),
      cmocka_unit_test(orthographic_sensor_rejects_null_arguments),
      cmocka_unit_test(orthographic_sensor_rejects_an_unknown_face),
      cmocka_unit_test(orthographic_sensor_rejects_a_direction_into_the_medium),
      cmocka_unit_test(orthographic_sensor_rejects_a_pixel_area_out_of_range),
      cmocka_unit_test(orthographic_sensor_rejects_a_direction_along_its_face),
      cmocka_unit_test(orthographic_sensor_rejects_a_zero_or_non_finite_direction),
      cmocka_unit_test(orthographic_sensor_rejects_a_direction_beyond_the_critical_angle),
      cmocka_unit_test(orthographic_sensor_rejects_non_positive_pixel_sizes),
      cmocka_unit_test(orthographic_sensor_rejects_a_non_finite_origin),
      cmocka_unit_test(orthographic_sensor_rejects_non_positive_pixel_counts),
      cmocka_unit_test(orthographic_sensor_rejects_overflowing_pixel_counts),
      cmocka_unit_test(hemispherical_detector_has_one_value),
      cmocka_unit_test(hemispherical_detector_rejects_null_arguments),
      cmocka_unit_test(hemispherical_detector_rejects_an_unknown_face),
      cmocka_unit_test(hemispherical_detector_rejects_a_rectangle_with_one_corner),
      cmocka_unit_test(hemispherical_detector_rejects_an_empty_or_non_finite_rectangle),
      cmocka_unit_test(sensor_queries_accept_null),
      cmocka_unit_test(sensor_destroy_accepts_null_and_clears_the_handle),
      cmocka_unit_test(steady_pathlength_has_one_bin),
      cmocka_unit_test(steady_pathlength_rejects_null_arguments),
      cmocka_unit_test(bins_report_their_count),
      cmocka_unit_test(bins_copy_their_centres),
      cmocka_unit_test(bins_reject_null_arguments),
      cmocka_unit_test(bins_reject_an_unknown_window),
      cmocka_unit_test(bins_reject_zero_bins),
      cmocka_unit_test(bins_reject_a_non_positive_width),
      cmocka_unit_test(bins_reject_a_non_finite_width),
      cmocka_unit_test(bins_reject_negative_centres),
      cmocka_unit_test(bins_reject_non_finite_centres),
      cmocka_unit_test(pathlength_destroy_accepts_null_and_clears_the_handle),
  };
  return cmocka_run_group_tests(tests, ht_context_setup, ht_context_teardown);
}
