/* The lane loop (transport/lanes.h) against the scalar photon loop: the
 * same photons traced four at a time must leave bitwise the same tally
 * (every value and every statistic) as hv_trace_photon one after another.
 * The media cover each way a lane leaves the vectors: exits through either
 * face, Fresnel reflection at a mismatched index, Russian roulette often,
 * the scattering bound, a purely absorbing medium and a vacuum, and both
 * forms of the Henyey–Greenstein inverse (|g| below and above 1/3, g < 0);
 * each as a uniform grid and with every voxel different (delta tracking,
 * tentative collisions kept and dropped, lanes with either form at once).
 * The photon range starts off zero and is longer than the lanes' record
 * ring, so lanes wait for a long path and refill out of order. */
#include <math.h>
#include <string.h>

#include "test_support.h"

#include "core/exponential.h"
#include "core/rng.h"
#include "medium/medium_internal.h"
#include "transport/grid.h"
#include "transport/lanes.h"
#include "transport/plan.h"
#include "transport/tracer.h"

enum { BINS = 5, VALUES = 2 * BINS, VOXELS = 4 * 4 * 2 };

typedef struct medium_case {
  const char *name;
  double sigma_a, sigma_s, g, eta;
  double roulette_weight, roulette_survival;
  int32_t min_scattering, max_scattering;
} medium_case_t;

static const medium_case_t CASES[] = {
    {"A1-like", 1.0, 10.0, 0.5, 1.0, 1e-4, 0.1, 0, 1000000},
    {"mismatched index, small g", 0.5, 5.0, 0.2, 1.37, 1e-4, 0.1, 0, 1000000},
    {"backward g, frequent roulette", 0.1, 3.0, -0.6, 1.0, 0.3, 0.5, 0, 1000000},
    {"scattering bound and minimum", 0.2, 8.0, 0.9, 1.2, 1e-4, 0.1, 2, 7},
    {"absorbing only", 2.0, 0.0, 0.0, 1.4, 1e-4, 0.1, 0, 1000000},
    {"vacuum", 0.0, 0.0, 0.3, 1.0, 1e-4, 0.1, 0, 1000000},
};

typedef struct scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *near, *far;
  hetinv_pathlength_t *bins;
  hetinv_measurements_t *set;
  hv_grid_t grid;
  hv_plans_t plans;
  hv_exp_table_t table;
  hv_tracer_t tracer;
} scene_t;

/* The voxels: all alike (a uniform grid), each different (delta tracking:
 * σa and σs within a factor 1.5 of the case's, g across both forms of the
 * inverse), the same with the case's g in every voxel (delta tracking
 * whose phase sampling keeps one g), or one dense voxel (stepping, which
 * the lanes do not take). */
typedef enum field { UNIFORM, VARIED, VARIED_SIGMA, DENSE } field_t;
enum { LANE_FIELDS = 3 }; /* the fields the lanes take: UNIFORM … VARIED_SIGMA */
static const char *const FIELD_NAMES[] = {"uniform", "varied", "varied-sigma", "dense"};

static void scene_make(scene_t *s, const medium_case_t *c, field_t field) {
  memset(s, 0, sizeof *s);
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  assert_ok(hetinv_context_create(&init, &s->ctx));
  assert_ok(hetinv_medium_create(s->ctx, (double[]){0, 0, 0}, (double[]){2, 2, 1}, (int32_t[]){4, 4, 2},
                                 &s->medium));
  assert_ok(hetinv_medium_fill(s->medium, c->sigma_a, c->sigma_s, c->g));
  if (field == DENSE) assert_ok(hetinv_medium_set_voxel(s->medium, 1, 2, 1, 1000.0, c->sigma_s, c->g));
  for (int32_t i = 0; (field == VARIED || field == VARIED_SIGMA) && i < 4 * 4 * 2; ++i) {
    double f = 0.75 + 0.5 * (double)((i * 7) % 11) / 10.0;
    double g = field == VARIED ? (double)((i * 5) % 9) / 5.0 - 0.8 : c->g;
    assert_ok(hetinv_medium_set_voxel(s->medium, i % 4, (i / 4) % 4, i / 16, c->sigma_a * f, c->sigma_s / f, g));
  }
  assert_ok(hetinv_medium_set_ior(s->medium, c->eta, 1.0));
  assert_ok(hetinv_medium_commit(s->medium));
  /* Oblique, so that the launch refracts and the box's side faces are met. */
  assert_ok(hetinv_emitter_create_ideal(s->medium, (double[]){0.7, 1.1, 2.0}, (double[]){0.3, -0.2, -1.0},
                                        &s->beam));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MAX, NULL, NULL, &s->near));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MIN, NULL, NULL, &s->far));
  double centres[BINS] = {0.5, 1.5, 2.5, 3.5, 4.5};
  assert_ok(hetinv_pathlength_create_bins(s->ctx, HETINV_WINDOW_BOX, BINS, centres, 1.0, &s->bins));
  assert_ok(hetinv_measurements_create(s->ctx, &s->set));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->near, s->bins, NULL));
  assert_ok(hetinv_measurements_add(s->set, s->beam, s->far, s->bins, NULL));
  assert_int_equal(hetinv_measurements_value_count(s->set), VALUES);
  assert_ok(hv_grid_build(s->medium, NULL, &s->grid));
  assert_ok(hv_plans_build(s->set, &s->plans));
  hv_exp_table_init(&s->table);
  s->tracer = (hv_tracer_t){.grid = &s->grid,
                            .exp_table = &s->table,
                            .roulette_weight = c->roulette_weight,
                            .roulette_survival = c->roulette_survival,
                            .min_scattering = c->min_scattering,
                            .max_scattering = c->max_scattering};
}

static void scene_release(scene_t *s) {
  hv_plans_release(&s->plans);
  hv_grid_release(&s->grid);
  hetinv_measurements_destroy(&s->set);
  hetinv_pathlength_destroy(&s->bins);
  hetinv_sensor_destroy(&s->near);
  hetinv_sensor_destroy(&s->far);
  hetinv_emitter_destroy(&s->beam);
  hetinv_medium_destroy(&s->medium);
  hetinv_context_destroy(&s->ctx);
}

static void lanes_leave_the_scalar_loops_tally_bit_for_bit(void **state) {
  (void)state;
  const uint64_t seed = UINT64_C(0x1a2e5), first = 17, end = 17 + 3001;
  const uint32_t stream = 3;
  for (size_t j = 0; j < LANE_FIELDS * sizeof CASES / sizeof CASES[0]; ++j) {
    size_t i = j / LANE_FIELDS;
    field_t field = (field_t)(j % LANE_FIELDS);
    scene_t s;
    scene_make(&s, &CASES[i], field);
    assert_int_equal(s.plans.count, 1);
    assert_true(field != UNIFORM || s.grid.uniform);
    assert_true(field == VARIED || s.grid.uniform_g);
    if (field != UNIFORM && !s.grid.delta) { /* a vacuum: nothing to track */
      assert_true(CASES[i].sigma_a + CASES[i].sigma_s == 0.0);
      scene_release(&s);
      continue;
    }
    const hv_plan_t *plan = &s.plans.plan[0];
    double v_scalar[VALUES] = {0}, v_lanes[VALUES] = {0};
    hv_tally_t scalar = {.values = v_scalar}, lanes = {.values = v_lanes};
    assert_true(hv_lanes_fit(&s.tracer, plan, &lanes));
    for (uint64_t p = first; p < end; ++p) {
      hv_rng_t rng = hv_rng_init(seed, plan->key, p, stream);
      hv_trace_photon(&s.tracer, plan, &rng, &scalar);
    }
    hv_trace_lanes(&s.tracer, plan, seed, stream, first, end, &lanes);
    print_message("%-30s %-12s near %.6f far %.6f absorbed %.6f truncated paths %g\n", CASES[i].name,
                  FIELD_NAMES[field], v_scalar[0] + v_scalar[1] + v_scalar[2] + v_scalar[3] + v_scalar[4],
                  v_scalar[5] + v_scalar[6] + v_scalar[7] + v_scalar[8] + v_scalar[9],
                  scalar.stats[HV_STAT_ABSORBED], scalar.stats[HV_STAT_TRUNCATED_PATHS]);
    assert_memory_equal(v_scalar, v_lanes, sizeof v_scalar);
    assert_memory_equal(scalar.stats, lanes.stats, sizeof scalar.stats);
    scene_release(&s);
  }
}

/* A gradient tally: every voxel free, a cotangent per value. */
typedef struct grad_tally {
  double values[VALUES], cotangent[VALUES], grad[3 * VOXELS];
  uint8_t touched[VOXELS];
  int64_t touched_list[VOXELS];
  hv_grad_tally_t gt;
  hv_tally_t tally;
} grad_tally_t;

static void grad_tally_init(grad_tally_t *g, const hetinv_context_t *ctx) {
  memset(g, 0, sizeof *g);
  for (int i = 0; i < VALUES; ++i) g->cotangent[i] = 1.0 + 0.25 * i;
  g->gt = (hv_grad_tally_t){.cotangent = g->cotangent, .grad = g->grad, .voxels = VOXELS, .touched = g->touched,
                            .touched_list = g->touched_list};
  g->gt.path.ctx = g->gt.chain.ctx = ctx;
  g->tally = (hv_tally_t){.values = g->values, .grad = &g->gt};
}

/* The gradient pass too: each photon's score log is the tally's while its
 * exit scores, and is applied in photon order, so the voxel gradient (and
 * the order voxels were first touched in) is bitwise the scalar loop's. */
static void lanes_leave_the_scalar_loops_gradient_bit_for_bit(void **state) {
  (void)state;
  const uint64_t seed = 99, first = 5, end = 5 + 1501;
  for (size_t j = 0; j < LANE_FIELDS * sizeof CASES / sizeof CASES[0]; ++j) {
    size_t i = j / LANE_FIELDS;
    field_t field = (field_t)(j % LANE_FIELDS);
    scene_t s;
    scene_make(&s, &CASES[i], field);
    const hv_plan_t *plan = &s.plans.plan[0];
    grad_tally_t *scalar = test_malloc(sizeof *scalar), *lanes = test_malloc(sizeof *lanes);
    grad_tally_init(scalar, s.ctx);
    grad_tally_init(lanes, s.ctx);
    if (!hv_lanes_fit(&s.tracer, plan, &lanes->tally)) { /* a vacuum of varied g */
      assert_true(field == VARIED && !s.grid.delta);
    } else {
      for (uint64_t p = first; p < end; ++p) {
        hv_rng_t rng = hv_rng_init(seed, plan->key, p, 0);
        hv_trace_photon(&s.tracer, plan, &rng, &scalar->tally);
      }
      hv_trace_lanes(&s.tracer, plan, seed, 0, first, end, &lanes->tally);
      assert_false(scalar->gt.path.out_of_memory || lanes->gt.path.out_of_memory);
      assert_memory_equal(scalar->grad, lanes->grad, sizeof scalar->grad);
      assert_int_equal(scalar->gt.touched_count, lanes->gt.touched_count);
      assert_memory_equal(scalar->touched_list, lanes->touched_list,
                          scalar->gt.touched_count * sizeof scalar->touched_list[0]);
      assert_memory_equal(scalar->tally.stats, lanes->tally.stats, sizeof scalar->tally.stats);
      double norm = 0.0;
      for (int k = 0; k < 3 * VOXELS; ++k) norm += fabs(scalar->grad[k]);
      assert_true(norm > 0.0 || CASES[i].sigma_s == 0.0 || CASES[i].sigma_a + CASES[i].sigma_s == 0.0);
    }
    hv_grad_tally_release_logs(&scalar->gt);
    hv_grad_tally_release_logs(&lanes->gt);
    test_free(scalar);
    test_free(lanes);
    scene_release(&s);
  }
}

/* Each case exercises what it is named for, or the comparison above
 * proves less than it claims. */
static void the_cases_reach_the_paths_they_are_named_for(void **state) {
  (void)state;
  double escaped_far[sizeof CASES / sizeof CASES[0]], truncated[sizeof CASES / sizeof CASES[0]];
  for (size_t i = 0; i < sizeof CASES / sizeof CASES[0]; ++i) {
    scene_t s;
    scene_make(&s, &CASES[i], UNIFORM);
    double v[VALUES] = {0};
    hv_tally_t t = {.values = v};
    hv_trace_lanes(&s.tracer, &s.plans.plan[0], 7, 0, 0, 2000, &t);
    escaped_far[i] = t.stats[HV_STAT_ESCAPED + HETINV_FACE_Z_MIN];
    truncated[i] = t.stats[HV_STAT_TRUNCATED_PATHS];
    if (CASES[i].eta != 1.0) assert_true(t.stats[HV_STAT_SPECULAR] > 0.0);
    scene_release(&s);
  }
  assert_true(truncated[3] > 0.0);       /* the scattering bound */
  assert_true(escaped_far[4] > 0.0);     /* some photons cross an absorbing slab unscattered */
  assert_true(escaped_far[5] > 1999.0);  /* a vacuum: every photon crosses (ideal beam, weight 1) */
}

static void only_uniform_or_delta_grids_without_vertex_sensors_or_tangents_fit(void **state) {
  (void)state;
  scene_t s;
  scene_make(&s, &CASES[0], DENSE);
  hv_tally_t t = {0};
  assert_false(s.grid.uniform || s.grid.delta);
  assert_false(hv_lanes_fit(&s.tracer, &s.plans.plan[0], &t)); /* stepping */
  scene_release(&s);
  scene_make(&s, &CASES[0], VARIED);
  assert_true(s.grid.delta);
  assert_true(hv_lanes_fit(&s.tracer, &s.plans.plan[0], &t));
  scene_release(&s);
  scene_make(&s, &CASES[0], UNIFORM);
  hv_grad_tally_t gt = {0};
  hv_tally_t g = {.grad = &gt};
  assert_true(hv_lanes_fit(&s.tracer, &s.plans.plan[0], &g));
  gt.jvp.tangents = 2; /* J·v: not in lanes */
  assert_false(hv_lanes_fit(&s.tracer, &s.plans.plan[0], &g));
  assert_true(hv_lanes_fit(&s.tracer, &s.plans.plan[0], &t));
  /* A camera scores next-event connections at every vertex. */
  hetinv_sensor_t *camera = NULL;
  assert_ok(hetinv_sensor_create_orthographic(s.medium, HETINV_FACE_Z_MAX, (double[]){0, 0, 1}, (double[]){0, 0},
                                              (double[]){1, 1}, 2, 2, &camera));
  hetinv_measurements_t *set = NULL;
  hv_plans_t plans;
  assert_ok(hetinv_measurements_create(s.ctx, &set));
  assert_ok(hetinv_measurements_add(set, s.beam, camera, s.bins, NULL));
  assert_ok(hv_plans_build(set, &plans));
  assert_false(hv_lanes_fit(&s.tracer, &plans.plan[0], &t));
  hv_plans_release(&plans);
  hetinv_measurements_destroy(&set);
  hetinv_sensor_destroy(&camera);
  scene_release(&s);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(lanes_leave_the_scalar_loops_tally_bit_for_bit),
      cmocka_unit_test(lanes_leave_the_scalar_loops_gradient_bit_for_bit),
      cmocka_unit_test(the_cases_reach_the_paths_they_are_named_for),
      cmocka_unit_test(only_uniform_or_delta_grids_without_vertex_sensors_or_tangents_fit),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
