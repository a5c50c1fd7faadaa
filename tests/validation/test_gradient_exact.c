/* Exact properties of the gradient pass, which hold for every random
 * number and are checked bit for bit:
 *
 * 1. A voxel no contributing path can reach has a gradient of exactly 0.
 *    Construction: an index-matched medium (η = η_out: no reflection, no
 *    refraction, so every flight is a straight segment) of 3 × 1 × 2 voxels
 *    (box [0, 3] × [0, 1] × [0, 2] mm: columns x ∈ [0,1], [1,2], [2,3]),
 *    a pencil beam entering the top of column 0 at (0.5, 0.5) straight
 *    down, and HETINV_ESTIMATOR_MAX_SCATTERING = 1. Every detector lies on
 *    the boundary of column 0: a hemispherical detector over its top
 *    square, one over the whole x = 0 face (column 0's side), one over its
 *    bottom square (with the ballistic beam), and an oblique orthographic
 *    pixel over its top square, steady and with a box pathlength bin.
 *    A contributing path is the beam segment inside column 0 (the beam
 *    never leaves it), at most one scattering vertex on it, then one
 *    straight segment (the rest of the flight, or the next-event
 *    connection) from that vertex to an exit point on column 0's boundary.
 *    Column 0 is convex, so both segments lie in it: no contributing path
 *    has a segment or a vertex in columns 1 and 2, and the measurements do
 *    not depend on their parameters at all — the derivative is exactly 0,
 *    not merely small. Photons do cross columns 1 and 2 (once-scattered
 *    light leaving elsewhere, truncated flights, connections that miss the
 *    pixel), so the estimator must give those segments no weight: 0.0
 *    exactly, not a Monte Carlo fluctuation around it.
 *    The same argument gives further exact zeros, listed at unreachable():
 *    the bottom voxel of column 0 for the oblique pixel, and voxel (2,0,0)
 *    and the g of columns 1–2 for a detector over the whole top face.
 *    Checked twice: with every voxel different, and with every voxel alike
 *    (the library's uniform-grid path logs whole straight segments and
 *    splits them into voxels only when a splat follows them).
 *    Controls that the zero is not vacuous: the same scene gives non-zero
 *    σa and σs gradients in column 1 when a hemispherical detector covers
 *    the whole top face (once-scattered light crosses it to get there),
 *    and when multiple scattering is allowed (MAX_SCATTERING = 0); and
 *    column 0's own gradients are non-zero.
 *
 * 2. Determinism: the gradient (and its standard errors) and the loss
 *    gradient are bitwise identical for contexts with 1, 2 and 3 threads
 *    and the same seed, on a refractive (η = 1.3) heterogeneous medium with
 *    two emitters, several rows, a coarse map and a photon count that is not
 *    a multiple of the batch count. */
#include <math.h>
#include <stdlib.h>

#include "test_gradient_common.h"

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0d01)

/* ------------------------------------------------------------------------ */
/* 1. Unreachable voxels */

typedef struct column_scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *top0, *side0, *bottom0, *pixel0, *top_all;
  hetinv_pathlength_t *steady, *bin;
  hetinv_param_map_t *map;
} column_scene_t;

/* uniform: every voxel alike (the library then takes its uniform-grid path,
 * which logs whole straight segments and splits them into voxels only
 * when a splat follows); otherwise every voxel different. */
static void column_scene_build(column_scene_t *s, int uniform) {
  s->ctx = val_context(seed, 1);
  assert_ok(hetinv_medium_create(s->ctx, (double[]){0, 0, 0}, (double[]){3, 1, 2}, (int32_t[]){3, 1, 2},
                                 &s->medium));
  assert_ok(hetinv_medium_set_ior(s->medium, 1.4, 1.4)); /* index matched */
  uint64_t table = 0xd0d0;
  for (int32_t z = 0; z < 2; ++z) {
    for (int32_t x = 0; x < 3; ++x) {
      double sa = 0.2 + 0.8 * grad_uniform(&table), ss = 0.5 + 1.5 * grad_uniform(&table);
      double g = 0.1 + 0.5 * grad_uniform(&table);
      if (uniform) sa = 0.5, ss = 1.2, g = 0.3;
      assert_ok(hetinv_medium_set_voxel(s->medium, x, 0, z, sa, ss, g));
    }
  }
  assert_ok(hetinv_medium_commit(s->medium));
  assert_ok(hetinv_emitter_create_ideal(s->medium, (double[]){0.5, 0.5, 3.0}, (double[]){0, 0, -1}, &s->beam));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MAX, (double[]){0, 0},
                                               (double[]){1, 1}, &s->top0));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_X_MIN, NULL, NULL, &s->side0));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MIN, (double[]){0, 0},
                                               (double[]){1, 1}, &s->bottom0));
  assert_ok(hetinv_sensor_create_orthographic(s->medium, HETINV_FACE_Z_MAX, (double[]){0.5, 0.0, 1.0},
                                              (double[]){0, 0}, (double[]){1, 1}, 1, 1, &s->pixel0));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MAX, NULL, NULL, &s->top_all));
  assert_ok(hetinv_pathlength_create_steady(s->ctx, &s->steady));
  assert_ok(hetinv_pathlength_create_bins(s->ctx, HETINV_WINDOW_BOX, 1, (double[]){2.0}, 1.0, &s->bin));
  assert_ok(hetinv_param_map_create_identity(s->medium, HETINV_FREE_ALL, &s->map));
}

static void column_scene_destroy(column_scene_t *s) {
  hetinv_param_map_destroy(&s->map);
  hetinv_pathlength_destroy(&s->bin);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_sensor_destroy(&s->top_all);
  hetinv_sensor_destroy(&s->pixel0);
  hetinv_sensor_destroy(&s->bottom0);
  hetinv_sensor_destroy(&s->side0);
  hetinv_sensor_destroy(&s->top0);
  hetinv_emitter_destroy(&s->beam);
  hetinv_medium_destroy(&s->medium);
  hetinv_context_destroy(&s->ctx);
}

/* Gradient (and its standard errors) of value n of a set for the 6 voxels,
 * all three parameters: grad[p·6 + k]. */
static void gradient_of(column_scene_t *s, hetinv_measurements_t *set, int max_scattering, int n,
                        double grad[18], double grad_se[18]) {
  hetinv_estimator_t *est = val_estimator(s->ctx, 2e5);
  /* Not scaled down: the zeros hold at any count, but the controls of
   * check_not_vacuous need enough photons to reach the bottom voxel, once
   * scattered, and come back out (at 10^4 photons none may). */
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, 2e5));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_MAX_SCATTERING, max_scattering));
  size_t count = hetinv_measurements_value_count(set);
  double *cot = calloc(count, sizeof *cot);
  assert_non_null(cot);
  cot[n] = 1.0;
  assert_ok(hetinv_estimator_gradient(est, s->medium, set, cot, count, s->map, grad, grad_se, 18));
  free(cot);
  hetinv_estimator_destroy(&est);
}

/* Which (voxel, parameter) no contributing path reaches, for each value
 * (k = x + 3z). See the file comment; the extra cases:
 * - the pixel (exit direction (0.5, 0, 1)/|·|, index matched, so the same
 *   inside) over column 0's top square [0, 1]²: a connection from a vertex
 *   at (0.5, 0.5, z) leaves the top at x = 0.5 + (2 − z)/2, inside the
 *   pixel only for z >= 1: vertices in voxel (0,0,0) never reach it, and
 *   the connections from voxel (0,0,1) stay in it, so only voxel (0,0,1)
 *   matters (for the steady value and for the bin alike);
 * - the whole top face with single scattering: the exit segment from a
 *   vertex (0.5, z_v) to a top point (x_e ≤ 3, 2) is at x ≤ 0.5 + 2.5·(1 −
 *   z_v)/(2 − z_v) ≤ 1.75 while z < 1, so it never enters voxel (2,0,0);
 *   and there are no vertices outside column 0, so g of columns 1 and 2
 *   has no effect. */
static int unreachable(int value, int k, hetinv_param_t p) {
  int x = k % 3;
  switch (value) {
    case 0: case 1: case 2: return x != 0;  /* column-0 hemispherical detectors */
    case 3: case 4: return k != 3;          /* the pixel: voxel (0,0,1) only */
    case 5: return k == 2 || (x != 0 && p == HETINV_PARAM_G); /* whole top face */
    default: return 0;
  }
}

static void check_unreachable(int uniform) {
  column_scene_t s;
  column_scene_build(&s, uniform);
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(s.ctx, &set));
  assert_ok(hetinv_measurements_add(set, s.beam, s.top0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.side0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.bottom0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.pixel0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.pixel0, s.bin, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.top_all, s.steady, NULL));
  static const char *const names[6] = {"hemi_top0",  "hemi_side0", "hemi_bottom0",
                                       "ortho0",     "ortho0_bin", "hemi_top_all"};
  int failures = 0, zeros = 0;
  for (int n = 0; n < 6; ++n) {
    double grad[18], grad_se[18];
    gradient_of(&s, set, 1, n, grad, grad_se);
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      for (int k = 0; k < 6; ++k) {
        double v = grad[p * 6 + k], se = grad_se[p * 6 + k];
        char what[96];
        snprintf(what, sizeof what, "unreachable/%s/%s/%s/(%d,0,%d)", uniform ? "uniform" : "varied",
                 names[n], hetinv_param_name(p), k % 3, k / 3);
        if (!unreachable(n, k, p)) {
          val_note("GRAD", what, v, se);
          continue;
        }
        ++zeros;
        failures += !val_check_exact("GRAD", what, 0.0, v, 0.0, seed);
        if (se != 0.0) {
          printf("  ... and its standard error is %g, not 0\n", se);
          ++failures;
        }
      }
    }
  }
  assert_int_equal(zeros, 3 * 12 + 2 * 15 + 6);
  hetinv_measurements_destroy(&set);
  column_scene_destroy(&s);
  val_assert_all_passed(failures);
}

/* Controls: gradients that are not zero. Column 0's voxels for the
 * column-0 detectors; voxel (1,0,1) for the whole top face with single
 * scattering (once-scattered light crosses it on its way out), and for
 * column 0's top detector with multiple scattering (light scattered in the
 * other columns comes back). Only well-populated entries are required to
 * be non-zero (so that the check holds at any photon count); the rest are
 * printed. */
static void check_not_vacuous(int uniform) {
  column_scene_t s;
  column_scene_build(&s, uniform);
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(s.ctx, &set));
  assert_ok(hetinv_measurements_add(set, s.beam, s.top0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.side0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.bottom0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.pixel0, s.steady, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.pixel0, s.bin, NULL));
  assert_ok(hetinv_measurements_add(set, s.beam, s.top_all, s.steady, NULL));
  const struct {
    const char *name;
    int value, max_scattering;
    int required[2]; /* voxels k = x + 3z whose σa and σs gradients must be non-zero; -1: none */
  } cases[] = {
      {"hemi_top0/single", 0, 1, {0, 3}},   {"hemi_side0/single", 1, 1, {0, 3}},
      {"hemi_bottom0/single", 2, 1, {0, 3}}, {"ortho0/single", 3, 1, {3, -1}},
      {"ortho0_bin/single", 4, 1, {3, -1}},  {"hemi_top_all/single", 5, 1, {4, -1}},
      {"hemi_top0/multiple", 0, 0, {4, -1}},
  };
  int failures = 0;
  for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
    double grad[18], grad_se[18];
    gradient_of(&s, set, cases[c].max_scattering, cases[c].value, grad, grad_se);
    for (hetinv_param_t p = 0; p < 2; ++p) {
      for (int k = 0; k < 6; ++k) {
        double v = grad[p * 6 + k], se = grad_se[p * 6 + k];
        int required = cases[c].required[0] == k || cases[c].required[1] == k;
        if (!required && cases[c].max_scattering == 1) continue; /* printed by the other test */
        char what[96];
        snprintf(what, sizeof what, "reachable/%s/%s/%s/(%d,0,%d)", uniform ? "uniform" : "varied",
                 cases[c].name, hetinv_param_name(p), k % 3, k / 3);
        val_note("GRAD", what, v, se);
        if (required && !(v != 0.0 && se > 0.0)) {
          printf("  ... expected a non-zero gradient\n");
          ++failures;
        }
      }
    }
  }
  hetinv_measurements_destroy(&set);
  column_scene_destroy(&s);
  val_assert_all_passed(failures);
}

static void unreachable_voxels_have_exactly_zero_gradient(void **state) {
  (void)state;
  check_unreachable(0);
}

static void unreachable_voxels_have_exactly_zero_gradient_uniform_grid(void **state) {
  (void)state;
  check_unreachable(1);
}

static void the_zero_is_not_vacuous(void **state) {
  (void)state;
  check_not_vacuous(0);
  check_not_vacuous(1);
}

/* ------------------------------------------------------------------------ */
/* 2. Determinism across thread counts */

typedef struct run {
  double grad[24], grad_se[24];
  double loss, rendered[16], loss_grad[24];
} run_t;

/* 10007 photons at scale 1 (2407 at 0.05): never a multiple of the 64 batches. */
#define DET_PHOTONS (2007.0 + floor(8000.0 * (double)HETINV_VALIDATION_SCALE + 0.5))

static void run_with_threads(int32_t threads, run_t *out) {
  hetinv_context_t *ctx = val_context(seed, threads);
  assert_int_equal(hetinv_context_thread_count(ctx), threads);
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){2, 2, 2}, (int32_t[]){4, 4, 2}, &m));
  assert_ok(hetinv_medium_set_ior(m, 1.3, 1.0));
  uint64_t table = 0xe7e7;
  for (int32_t z = 0; z < 2; ++z) {
    for (int32_t y = 0; y < 4; ++y) {
      for (int32_t x = 0; x < 4; ++x) {
        assert_ok(hetinv_medium_set_voxel(m, x, y, z, 0.2 + 0.8 * grad_uniform(&table),
                                          1.0 + 4.0 * grad_uniform(&table), 0.1 + 0.5 * grad_uniform(&table)));
      }
    }
  }
  assert_ok(hetinv_medium_commit(m));
  hetinv_emitter_t *beam = NULL, *area = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.7, 1.1, 3.0}, (double[]){0.2, 0.1, -1.0}, &beam));
  assert_ok(hetinv_emitter_create_area(m, HETINV_FACE_Z_MAX, (double[]){0, 0, -1}, (double[]){0.5, 0.5},
                                       (double[]){1.5, 1.0}, 1, 1, NULL, &area));
  hetinv_sensor_t *pixels = NULL, *hemi = NULL;
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MAX, (double[]){0.2, -0.1, 1.0},
                                              (double[]){0.0, 0.0}, (double[]){1.0, 1.0}, 2, 2, &pixels));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &hemi));
  hetinv_pathlength_t *steady = NULL, *bins = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_GAUSSIAN, 2, (double[]){2.0, 4.0}, 1.0, &bins));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, pixels, steady, NULL));  /* 4 values */
  assert_ok(hetinv_measurements_add(set, area, pixels, bins, NULL));    /* 8 values */
  assert_ok(hetinv_measurements_add(set, beam, hemi, steady, NULL));    /* 1 value */
  assert_ok(hetinv_measurements_add(set, area, hemi, bins, NULL));      /* 2 values */
  size_t count = hetinv_measurements_value_count(set);
  assert_int_equal(count, 15);
  double cot[15], measured[15];
  for (size_t i = 0; i < count; ++i) {
    cot[i] = (i % 3 == 0 ? -1.0 : 0.5) * (1.0 + (double)i);
    measured[i] = 0.01 * (double)i;
  }
  assert_ok(hetinv_measurements_set_values(set, measured, NULL, count));
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){2, 2, 2}, HETINV_FREE_ALL, &map));
  assert_int_equal(hetinv_param_map_size(map), 24);
  hetinv_estimator_t *est = NULL;
  assert_ok(hetinv_estimator_create(ctx, &est));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, DET_PHOTONS));
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 3));
  assert_ok(hetinv_estimator_gradient(est, m, set, cot, count, map, out->grad, out->grad_se, 24));
  assert_ok(hetinv_estimator_loss_gradient(est, m, set, map, &out->loss, out->rendered, out->loss_grad, 24));
  /* The same call again on the same estimator gives the same bits. */
  double again[24];
  assert_ok(hetinv_estimator_gradient(est, m, set, cot, count, map, again, NULL, 24));
  assert_memory_equal(again, out->grad, sizeof again);
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&bins);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&hemi);
  hetinv_sensor_destroy(&pixels);
  hetinv_emitter_destroy(&area);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
}

static int same_bits(const char *what, const double *a, const double *b, size_t n) {
  double worst = 0.0;
  for (size_t i = 0; i < n; ++i) worst = fmax(worst, fabs(a[i] - b[i]));
  int pass = memcmp(a, b, n * sizeof *a) == 0;
  printf("VALIDATION GRAD determinism/%s max|diff|=%.3g bitwise=%s seed=%llu %s\n", what, worst,
         pass ? "yes" : "no", (unsigned long long)seed, pass ? "PASS" : "FAIL");
  return pass;
}

static void gradient_is_bitwise_identical_across_thread_counts(void **state) {
  (void)state;
  run_t *runs = calloc(3, sizeof *runs);
  assert_non_null(runs);
  for (int t = 0; t < 3; ++t) run_with_threads(t + 1, &runs[t]);
  int failures = 0;
  for (int t = 1; t < 3; ++t) {
    char what[64];
    snprintf(what, sizeof what, "grad/threads1_vs_%d", t + 1);
    failures += !same_bits(what, runs[0].grad, runs[t].grad, 24);
    snprintf(what, sizeof what, "grad_se/threads1_vs_%d", t + 1);
    failures += !same_bits(what, runs[0].grad_se, runs[t].grad_se, 24);
    snprintf(what, sizeof what, "loss/threads1_vs_%d", t + 1);
    failures += !same_bits(what, &runs[0].loss, &runs[t].loss, 1);
    snprintf(what, sizeof what, "rendered/threads1_vs_%d", t + 1);
    failures += !same_bits(what, runs[0].rendered, runs[t].rendered, 15);
    snprintf(what, sizeof what, "loss_grad/threads1_vs_%d", t + 1);
    failures += !same_bits(what, runs[0].loss_grad, runs[t].loss_grad, 24);
  }
  /* Not vacuous: a real gradient. */
  int nonzero = 0;
  for (int k = 0; k < 24; ++k) nonzero += runs[0].grad[k] != 0.0 && runs[0].grad_se[k] > 0.0;
  assert_int_equal(nonzero, 24);
  free(runs);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(unreachable_voxels_have_exactly_zero_gradient),
      cmocka_unit_test(unreachable_voxels_have_exactly_zero_gradient_uniform_grid),
      cmocka_unit_test(the_zero_is_not_vacuous),
      cmocka_unit_test(gradient_is_bitwise_identical_across_thread_counts),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
