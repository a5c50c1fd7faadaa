/* Pathlength bins seen through an instrument response function
 * (hetinv_pathlength_create_bins_irf) and the picosecond time axis
 * (hetinv_irf_offsets_from_times). On one random stream the photons are the
 * same whatever the windows, so the checks are exact: a delta IRF gives the
 * bare bins bit for bit, and a two-tap IRF gives the two-tap convolution of
 * bins one spacing wider, to rounding, for the values and the gradient.
 * White-box (the optimizer's stages): layer-wise value masks count an IRF's
 * earliest tap. */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "test_support.h"
#include "optimize/optimizer_internal.h" /* white-box: the layer-wise stages' value masks */

#define NaN ((double)NAN)
#define Inf ((double)INFINITY)

enum { BINS = 6, PIXELS = 4 };
#define SPACING 4.0 /* bin width and spacing (mm) */

typedef struct scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *ortho, *reflect;
  hetinv_param_map_t *map;
  hetinv_estimator_t *est;
  size_t k;
} scene_t;

static void scene_init(scene_t *s) {
  *s = (scene_t){0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 2;
  init.seed = 5;
  assert_ok(hetinv_context_create(&init, &s->ctx));
  assert_ok(hetinv_medium_create(s->ctx, (double[]){0, 0, 0}, (double[]){10, 10, 10},
                                 (int32_t[]){2, 2, 2}, &s->medium));
  assert_ok(hetinv_medium_fill(s->medium, 0.05, 0.8, 0.3));
  assert_ok(hetinv_medium_set_voxel(s->medium, 1, 1, 0, 0.2, 1.5, -0.2));
  assert_ok(hetinv_medium_set_ior(s->medium, 1.4, 1.0));
  assert_ok(hetinv_medium_commit(s->medium));
  assert_ok(hetinv_emitter_create_ideal(s->medium, (double[]){4, 3, -1}, (double[]){0, 0, 1}, &s->beam));
  assert_ok(hetinv_sensor_create_orthographic(s->medium, HETINV_FACE_Z_MIN, (double[]){0, 0, -1},
                                              (double[]){0, 0}, (double[]){5, 5}, 2, 2, &s->ortho));
  assert_ok(hetinv_sensor_create_hemispherical(s->medium, HETINV_FACE_Z_MIN, NULL, NULL, &s->reflect));
  assert_ok(hetinv_param_map_create_identity(s->medium, HETINV_FREE_ALL, &s->map));
  s->k = hetinv_param_map_size(s->map);
  assert_ok(hetinv_estimator_create(s->ctx, &s->est));
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_PHOTONS, 1500));
  assert_ok(hetinv_estimator_set_param(s->est, HETINV_ESTIMATOR_BATCHES, 16));
}

static void scene_release(scene_t *s) {
  hetinv_estimator_destroy(&s->est);
  hetinv_param_map_destroy(&s->map);
  hetinv_sensor_destroy(&s->ortho);
  hetinv_sensor_destroy(&s->reflect);
  hetinv_emitter_destroy(&s->beam);
  hetinv_medium_destroy(&s->medium);
  hetinv_context_destroy(&s->ctx);
}

/* A set of two rows through pathlength pl: the 2 x 2 camera and the
 * hemispherical reflectance; (PIXELS + 1)·bins values. */
static hetinv_measurements_t *make_set(const scene_t *s, const hetinv_pathlength_t *pl) {
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(s->ctx, &set));
  assert_ok(hetinv_measurements_add(set, s->beam, s->ortho, pl, NULL));
  assert_ok(hetinv_measurements_add(set, s->beam, s->reflect, pl, NULL));
  return set;
}

/* Renders the set of pl: values and errors, and the gradient for the
 * cotangent cot (NULL: 1, 2, 3, ...). */
static void run(scene_t *s, const hetinv_pathlength_t *pl, double *values, double *errors,
                const double *cot, double *grad) {
  hetinv_measurements_t *set = make_set(s, pl);
  size_t n = hetinv_measurements_value_count(set);
  assert_ok(hetinv_estimator_render(s->est, s->medium, set, values, errors, NULL, n));
  double *c = calloc(n, sizeof(double));
  assert_non_null(c);
  for (size_t i = 0; i < n; ++i) c[i] = cot ? cot[i] : (double)(i + 1);
  assert_ok(hetinv_estimator_gradient(s->est, s->medium, set, c, n, s->map, grad, NULL, s->k));
  free(c);
  hetinv_measurements_destroy(&set);
}

static void centres_from(double first, int count, double *c) {
  for (int b = 0; b < count; ++b) c[b] = first + SPACING * b;
}

/* A one-sample IRF at offset 0 (and one padded with zero samples
 * elsewhere) is the bare bins, bit for bit, for box and Gaussian windows. */
static void delta_irf_gives_the_bare_bins_bit_for_bit(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  enum { N = (PIXELS + 1) * BINS };
  double c[BINS];
  centres_from(2.0, BINS, c);
  for (int w = 0; w < 2; ++w) {
    hetinv_window_t window = w ? HETINV_WINDOW_GAUSSIAN : HETINV_WINDOW_BOX;
    double width = w ? 1.5 : SPACING;
    hetinv_pathlength_t *bare = NULL, *delta = NULL, *padded = NULL;
    assert_ok(hetinv_pathlength_create_bins(s.ctx, window, BINS, c, width, &bare));
    assert_ok(hetinv_pathlength_create_bins_irf(s.ctx, window, BINS, c, width, 1, (double[]){0.0},
                                                (double[]){5.0}, &delta));
    assert_ok(hetinv_pathlength_create_bins_irf(s.ctx, window, BINS, c, width, 3,
                                                (double[]){-2.0, 0.0, 7.0}, (double[]){0.0, 3.0, 0.0},
                                                &padded));
    double v0[N], e0[N], g0[24], v1[N], e1[N], g1[24];
    run(&s, bare, v0, e0, NULL, g0);
    const hetinv_pathlength_t *irfs[2] = {delta, padded};
    for (int i = 0; i < 2; ++i) {
      run(&s, irfs[i], v1, e1, NULL, g1);
      assert_memory_equal(v0, v1, sizeof v0);
      assert_memory_equal(e0, e1, sizeof e0);
      assert_memory_equal(g0, g1, sizeof g0);
    }
    double total = 0.0;
    for (int i = 0; i < N; ++i) total += v0[i];
    assert_true(total > 0.0); /* the bins see light: the comparison is not of zeros */
    hetinv_pathlength_destroy(&bare);
    hetinv_pathlength_destroy(&delta);
    hetinv_pathlength_destroy(&padded);
  }
  scene_release(&s);
}

/* IRF h = (3, 1)/4 at offsets (0, Δ), Δ the bin spacing: a photon of
 * pathlength τ is seen at τ (weight 3/4) and at τ + Δ (1/4), so bin b is
 * 3/4·I_b + 1/4·I_{b−1}, where I_{−1} is the bin before the first: the
 * reference renders bins starting one spacing earlier. Same photons, so
 * equal to rounding. The gradient with cotangent u is the reference's with
 * the transposed cotangent u'_j = 3/4·u_{j−1} + 1/4·u_j (reference bin j
 * is IRF bin j − 1; u_{−1} = u_BINS = 0). */
static void two_tap_irf_is_the_convolution_of_the_bins(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  enum { N = (PIXELS + 1) * BINS, NR = (PIXELS + 1) * (BINS + 1) };
  double c[BINS], cr[BINS + 1];
  centres_from(4.0, BINS, c);
  centres_from(4.0 - SPACING, BINS + 1, cr);
  hetinv_pathlength_t *irf = NULL, *ref = NULL;
  assert_ok(hetinv_pathlength_create_bins_irf(s.ctx, HETINV_WINDOW_BOX, BINS, c, SPACING, 2,
                                              (double[]){0.0, SPACING}, (double[]){3.0, 1.0}, &irf));
  assert_ok(hetinv_pathlength_create_bins(s.ctx, HETINV_WINDOW_BOX, BINS + 1, cr, SPACING, &ref));
  double v[N], e[N], g[24], vr[NR], er[NR], gr[24], cot[N], cot_r[NR];
  for (int i = 0; i < N; ++i) cot[i] = cos(0.7 * i); /* any cotangent, of either sign */
  /* Rows are (camera: PIXELS per bin, bin-major) then (reflectance: 1 per bin). */
  const int offset[2] = {0, PIXELS * BINS}, offset_r[2] = {0, PIXELS * (BINS + 1)};
  const int pixels[2] = {PIXELS, 1};
  for (int row = 0; row < 2; ++row) {
    for (int p = 0; p < pixels[row]; ++p) {
      for (int b = 0; b <= BINS; ++b) {
        double up = b < BINS ? cot[offset[row] + b * pixels[row] + p] : 0.0;   /* u_b */
        double down = b > 0 ? cot[offset[row] + (b - 1) * pixels[row] + p] : 0.0; /* u_{b-1} */
        /* reference bin b is irf bin b - 1 (weight 3/4) and feeds irf bin b (1/4) */
        cot_r[offset_r[row] + b * pixels[row] + p] = 0.75 * down + 0.25 * up;
      }
    }
  }
  run(&s, irf, v, e, cot, g);
  run(&s, ref, vr, er, cot_r, gr);
  double seen = 0.0;
  for (int row = 0; row < 2; ++row) {
    for (int p = 0; p < pixels[row]; ++p) {
      for (int b = 0; b < BINS; ++b) {
        double late = vr[offset_r[row] + (b + 1) * pixels[row] + p];
        double early = vr[offset_r[row] + b * pixels[row] + p];
        double expect = 0.75 * late + 0.25 * early;
        double got = v[offset[row] + b * pixels[row] + p];
        if (!(fabs(got - expect) <= 1e-12 * (late + early))) {
          print_error("row %d pixel %d bin %d: %.17g, expected %.17g\n", row, p, b, got, expect);
          fail();
        }
        seen += early > 0.0 && late > 0.0;
      }
    }
  }
  assert_true(seen >= 4); /* several bins mix two non-zero neighbours */
  double scale = 0.0;
  for (size_t i = 0; i < s.k; ++i) scale = fmax(scale, fabs(gr[i]));
  assert_true(scale > 0.0);
  for (size_t i = 0; i < s.k; ++i) {
    if (!(fabs(g[i] - gr[i]) <= 1e-10 * scale)) {
      print_error("grad[%zu] = %.17g, expected %.17g\n", i, g[i], gr[i]);
      fail();
    }
  }
  hetinv_pathlength_destroy(&irf);
  hetinv_pathlength_destroy(&ref);
  scene_release(&s);
}

/* An IRF only redistributes light over the bins: with bins that partition
 * all pathlengths reached (and every tap's shift kept inside them), the
 * sum over bins is that of the bare bins, to rounding, and the mean
 * pathlength moves by the IRF's mean offset (to within a bin width: each
 * binned pathlength is off by at most half a bin). */
static void irf_keeps_the_total_and_shifts_the_mean(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  enum { B = 320, N = (PIXELS + 1) * B };
  const double width = 0.5;
  static double c[B], v0[N], v1[N];
  for (int b = 0; b < B; ++b) c[b] = width * (b + 0.5); /* [0, 160): beyond every path */
  assert_ok(hetinv_estimator_set_param(s.est, HETINV_ESTIMATOR_MAX_SCATTERING, 30));
  hetinv_pathlength_t *bare = NULL, *irf = NULL;
  const double d[4] = {0.3, 1.1, 2.9, 5.0}, h[4] = {1.0, 4.0, 2.0, 0.5};
  double mean_offset = 0.0;
  for (int j = 0; j < 4; ++j) mean_offset += d[j] * h[j] / 7.5;
  assert_ok(hetinv_pathlength_create_bins(s.ctx, HETINV_WINDOW_BOX, B, c, width, &bare));
  assert_ok(hetinv_pathlength_create_bins_irf(s.ctx, HETINV_WINDOW_BOX, B, c, width, 4, d, h, &irf));
  double g[24];
  run(&s, bare, v0, NULL, NULL, g);
  run(&s, irf, v1, NULL, NULL, g);
  for (int row = 0; row < 2; ++row) {
    int px = row ? 1 : PIXELS, off = row ? PIXELS * B : 0;
    for (int p = 0; p < px; ++p) {
      double a = 0.0, b = 0.0, ma = 0.0, mb = 0.0;
      for (int k = 0; k < B; ++k) {
        a += v0[off + k * px + p];
        b += v1[off + k * px + p];
        ma += c[k] * v0[off + k * px + p];
        mb += c[k] * v1[off + k * px + p];
      }
      assert_true(a > 0.0);
      assert_true(fabs(a - b) <= 1e-12 * a);
      double shift = mb / b - ma / a;
      if (!(fabs(shift - mean_offset) <= width)) {
        print_error("row %d pixel %d: the mean moved by %g, the IRF's mean offset is %g\n", row, p,
                    shift, mean_offset);
        fail();
      }
    }
  }
  hetinv_pathlength_destroy(&bare);
  hetinv_pathlength_destroy(&irf);
  scene_release(&s);
}

static void malformed_irf_gets_a_precise_error(void **state) {
  (void)state;
  scene_t s;
  scene_init(&s);
  hetinv_pathlength_t *p = (hetinv_pathlength_t *)&s; /* must be set to NULL on failure */
  const double c[2] = {1, 5};
  const double off[2] = {0, 1};
#define BAD(code, n, o, h, text) \
  do { \
    assert_result(code, hetinv_pathlength_create_bins_irf(s.ctx, HETINV_WINDOW_BOX, 2, c, 4.0, n, o, h, &p)); \
    assert_null(p); \
    assert_message_contains(text); \
    p = (hetinv_pathlength_t *)&s; \
  } while (0)
  BAD(HETINV_ERROR_NULL_ARGUMENT, 2, NULL, ((double[]){1, 1}), "'irf_offsets' is NULL");
  BAD(HETINV_ERROR_NULL_ARGUMENT, 2, off, NULL, "'irf_samples' is NULL");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, 0, off, ((double[]){1, 1}), "irf_count is 0");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, HETINV_MAX_IRF_SAMPLES + 1, off, ((double[]){1, 1}),
      "irf_count is 65537");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, 2, off, ((double[]){1, NaN}), "irf_samples[1] (offset 1) is nan");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, 2, off, ((double[]){-0.5, 1}), "irf_samples[0] (offset 0) is -0.5");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, 2, off, ((double[]){Inf, 1}), "irf_samples[0] (offset 0) is inf");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, 2, ((double[]){0, NaN}), ((double[]){1, 1}), "irf_offsets[1] is nan");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, 2, off, ((double[]){0, 0}), "the 2 IRF samples sum to 0");
  BAD(HETINV_ERROR_INVALID_ARGUMENT, 2, off, ((double[]){1e308, 1e308}), "sum to inf");
  /* the bins' own checks still apply */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_pathlength_create_bins_irf(s.ctx, HETINV_WINDOW_BOX, 2, c, -1.0, 2, off,
                                                  (double[]){1, 1}, &p));
  assert_message_contains("width is -1");
  assert_null(p);
#undef BAD
  scene_release(&s);
}

static void times_convert_to_pathlengths_in_the_medium(void **state) {
  (void)state;
  double t[3] = {1000.0, -50.0, 0.0}, d[3];
  assert_ok(hetinv_irf_offsets_from_times(t, 3, 1.0, 1.0, d));
  assert_true(fabs(d[0] - 299.792458) <= 1e-12);
  assert_true(fabs(d[1] + 14.9896229) <= 1e-12);
  assert_true(d[2] == 0.0);
  /* η = 1.4, centimetres: c₀ t / η in cm */
  assert_ok(hetinv_irf_offsets_from_times(t, 3, 1.4, 10.0, d));
  assert_true(fabs(d[0] - 299.792458 / 1.4 / 10.0) <= 1e-13);
  /* in place */
  assert_ok(hetinv_irf_offsets_from_times(t, 3, 1.0, 1000.0, t));
  assert_true(fabs(t[0] - 0.299792458) <= 1e-15);
  double keep[2] = {7.0, 8.0};
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_irf_offsets_from_times((double[]){1.0, NaN}, 2, 1.3, 1.0, keep));
  assert_message_contains("times_ps[1] is nan");
  assert_true(keep[0] == 7.0 && keep[1] == 8.0); /* nothing written */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_irf_offsets_from_times(d, 1, 0.5, 1.0, keep));
  assert_message_contains("eta is 0.5");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_irf_offsets_from_times(d, 1, NaN, 1.0, keep));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_irf_offsets_from_times(d, 1, 1.0, 0.0, keep));
  assert_message_contains("length_unit_mm is 0");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_irf_offsets_from_times((double[]){1e308}, 1, 1.0, 1e-300, keep));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_irf_offsets_from_times(NULL, 1, 1.0, 1.0, keep));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_irf_offsets_from_times(d, 1, 1.0, 1.0, NULL));
  assert_ok(hetinv_irf_offsets_from_times(NULL, 0, 1.0, 1.0, NULL));
}

/* A layer-wise stage keeps a bin only if no path that reaches below the
 * layer can be scored in it. Through an IRF with a tap at offset -0.5 a
 * path of length τ is also scored at τ - 0.5, so a bin [c - w/2, c + w/2)
 * collects paths up to c + w/2 + 0.5: the mask of optimize_stages's
 * layerwise test with every window end moved 0.5 later. */
static void layerwise_masks_count_the_irf_early_tap(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){3, 1, 3}, &m));
  assert_ok(hetinv_medium_fill(m, 0.5, 3.0, 0.0));
  assert_ok(hetinv_medium_set_ior(m, 1.3, 1.0));
  assert_ok(hetinv_medium_commit(m));
  hetinv_emitter_t *beam = NULL;
  hetinv_sensor_t *reflect = NULL;
  hetinv_pathlength_t *pl = NULL;
  hetinv_measurements_t *set = NULL;
  hetinv_param_map_t *map = NULL;
  hetinv_optimizer_t *opt = NULL;
  enum { B = 16 };
  const double w = 0.25, early = 0.5;
  double c[B];
  for (int b = 0; b < B; ++b) c[b] = (b + 0.5) * w;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.5, 0.5, -1}, (double[]){0, 0, 1}, &beam));
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MIN, (double[]){0, 0, -1}, (double[]){0, 0},
                                              (double[]){1.0 / 3, 1}, 3, 1, &reflect));
  assert_ok(hetinv_pathlength_create_bins_irf(ctx, HETINV_WINDOW_BOX, B, c, w, 2, (double[]){-early, 0.0},
                                              (double[]){1.0, 1.0}, &pl));
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, reflect, pl, NULL));
  assert_ok(hetinv_param_map_create_identity(m, HETINV_FREE(HETINV_PARAM_SIGMA_S), &map));
  assert_ok(hetinv_optimizer_create(ctx, set, m, &opt));
  const double h = 1.0 / 3;
  assert_ok(hetinv_optimizer_add_layerwise_stages(opt, map, h, 3, 4));
  assert_int_equal(opt->stage_count, 3);
  int kept = 0, dropped_by_irf = 0;
  for (int n = 0; n < 3; ++n) {
    for (int b = 0; b < B; ++b) {
      for (int px = 0; px < 3; ++px) {
        double d = (px + 0.5) / 3 - 0.5, depth2 = 2 * (n + 1) * h, shortest = sqrt(d * d + depth2 * depth2);
        bool keep = (b + 1) * w + early <= shortest;
        assert_int_equal(opt->stages[n].value_mask[(size_t)b * 3 + (size_t)px] != 0, keep);
        kept += keep;
        dropped_by_irf += !keep && (b + 1) * w <= shortest;
      }
    }
  }
  assert_true(kept > 0 && dropped_by_irf > 0); /* the test sees both kinds of bins */
  hetinv_optimizer_destroy(&opt);
  hetinv_param_map_destroy(&map);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&pl);
  hetinv_sensor_destroy(&reflect);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(delta_irf_gives_the_bare_bins_bit_for_bit),
      cmocka_unit_test(two_tap_irf_is_the_convolution_of_the_bins),
      cmocka_unit_test(irf_keeps_the_total_and_shifts_the_mean),
      cmocka_unit_test(malformed_irf_gets_a_precise_error),
      cmocka_unit_test(times_convert_to_pathlengths_in_the_medium),
      cmocka_unit_test(layerwise_masks_count_the_irf_early_tap),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
