/* Pathlength-resolved measurements (W_τ box windows) against steady state.
 *
 * 1. Box bins of width w at spacing w from τ = 0 to τ_max, plus one
 *    catch-all bin [τ_max, τ_max + 2^40), partition the pathlengths, so for
 *    the same photons (rows of one emitter share them) every contribution
 *    lands in exactly one bin: Σ bins + catch-all = steady state, exactly
 *    up to the rounding of summing the same terms in a different grouping.
 *    The catch-all bin must hold a negligible part (τ_max is chosen so).
 *
 * 2. The pathlength τ is the geometric length travelled inside the medium,
 *    so adding a uniform absorption δ to every voxel multiplies each
 *    contribution by e^{-δτ} (microscopic Beer–Lambert law):
 *      I(σa + δ) = Σ_b I_b(σa) e^{-δ τ_b}.
 *    Comparing the right side with an independent render of the medium
 *    with σa + δ checks the τ of every kind of contribution: photons
 *    leaving through a hemispherical detector, and next-event connections to
 *    an orthographic sensor (τ = length to the vertex + connection length,
 *    including the connection's specular bounces). Using the bin centre τ_b
 *    errs by at most a factor e^{±δw/2} per bin; that bound is carried as
 *    the reference's precision.
 *
 * Medium: a 3 × 3 × 1.5 mm heterogeneous box, η = 1.3, pencil beam into the
 * top face; a hemispherical detector over a region of the top face, one
 * over the whole bottom face, and a 2 × 2 orthographic sensor on the top
 * face. */
#include <float.h>
#include <math.h>
#include <stdlib.h>

#include "validation.h"

/* 2 hemispherical values + 4 pixels, in the reweighting test. */
#define COMPARISONS 6
#define VALUES 6   /* per bin: hemi top, hemi bottom, 4 pixels */
#define REPLICAS 32

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed005b)

/* Bins: w = 2^-8 mm up to τ_max = 64 mm. Beyond τ_max every path has lost
 * at least 1 - e^{-σa_min τ_max} = 1 - e^{-0.3·64} = 1 - 5e-9 of its weight to
 * absorption: negligible against every error bar. */
static const double bin_w = 1.0 / 256.0, tau_max = 64.0;
#define BINS 16384
static const double delta = 0.25; /* added absorption, 1/mm */

static const double box_lo[3] = {0.0, 0.0, 0.0}, box_hi[3] = {3.0, 3.0, 1.5};
static const val_ranges_t ranges = {{0.3, 0.8}, {1.0, 4.0}, {0.0, 0.7}};

typedef struct scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium, *absorbing; /* σa, and σa + δ */
  hetinv_emitter_t *beam;
  hetinv_sensor_t *sensors[3];
  hetinv_pathlength_t *steady, *bins, *tail;
  hetinv_measurements_t *set;   /* per sensor: steady, bins, tail rows */
  hetinv_measurements_t *plain; /* per sensor: steady */
} scene_t;

static scene_t make_scene(void) {
  scene_t s = {0};
  s.ctx = val_context(seed, 1);
  s.medium = val_heterogeneous(s.ctx, box_lo, box_hi, (int32_t[]){4, 4, 2}, &ranges, seed, 1.3, 1.0);
  assert_ok(hetinv_medium_clone(s.medium, &s.absorbing));
  assert_ok(hetinv_medium_commit(s.medium));
  for (int32_t iz = 0; iz < 2; ++iz) {
    for (int32_t iy = 0; iy < 4; ++iy) {
      for (int32_t ix = 0; ix < 4; ++ix) {
        double a, b, g;
        assert_ok(hetinv_medium_get_voxel(s.medium, ix, iy, iz, &a, &b, &g));
        assert_ok(hetinv_medium_set_voxel(s.absorbing, ix, iy, iz, a + delta, b, g));
      }
    }
  }
  assert_ok(hetinv_medium_commit(s.absorbing));
  assert_ok(hetinv_emitter_create_ideal(s.medium, (double[]){1.4, 1.6, 3.0},
                                        (double[]){0.1, -0.15, -1.0}, &s.beam));
  assert_ok(hetinv_sensor_create_hemispherical(s.medium, HETINV_FACE_Z_MAX, (double[]){0.4, 0.8},
                                               (double[]){2.2, 2.6}, &s.sensors[0]));
  assert_ok(hetinv_sensor_create_hemispherical(s.medium, HETINV_FACE_Z_MIN, NULL, NULL, &s.sensors[1]));
  assert_ok(hetinv_sensor_create_orthographic(s.medium, HETINV_FACE_Z_MAX, (double[]){-0.3, 0.2, 0.9},
                                              (double[]){0.6, 0.9}, (double[]){0.6, 0.6}, 2, 2,
                                              &s.sensors[2]));
  double *centres = malloc(BINS * sizeof *centres);
  assert_non_null(centres);
  for (int i = 0; i < BINS; ++i) centres[i] = (i + 0.5) * bin_w; /* exact in binary */
  assert_ok(hetinv_pathlength_create_bins(s.ctx, HETINV_WINDOW_BOX, BINS, centres, bin_w, &s.bins));
  free(centres);
  const double huge = 0x1p40;
  assert_ok(hetinv_pathlength_create_bins(s.ctx, HETINV_WINDOW_BOX, 1, (double[]){tau_max + 0.5 * huge},
                                          huge, &s.tail));
  assert_ok(hetinv_pathlength_create_steady(s.ctx, &s.steady));
  assert_ok(hetinv_measurements_create(s.ctx, &s.set));
  assert_ok(hetinv_measurements_create(s.ctx, &s.plain));
  for (int i = 0; i < 3; ++i) {
    assert_ok(hetinv_measurements_add(s.set, s.beam, s.sensors[i], s.steady, NULL));
    assert_ok(hetinv_measurements_add(s.set, s.beam, s.sensors[i], s.bins, NULL));
    assert_ok(hetinv_measurements_add(s.set, s.beam, s.sensors[i], s.tail, NULL));
    assert_ok(hetinv_measurements_add(s.plain, s.beam, s.sensors[i], s.steady, NULL));
  }
  return s;
}

static void free_scene(scene_t *s) {
  hetinv_measurements_destroy(&s->set);
  hetinv_measurements_destroy(&s->plain);
  hetinv_pathlength_destroy(&s->steady);
  hetinv_pathlength_destroy(&s->bins);
  hetinv_pathlength_destroy(&s->tail);
  for (int i = 0; i < 3; ++i) hetinv_sensor_destroy(&s->sensors[i]);
  hetinv_emitter_destroy(&s->beam);
  hetinv_medium_destroy(&s->medium);
  hetinv_medium_destroy(&s->absorbing);
  hetinv_context_destroy(&s->ctx);
}

/* Value v (0..5: hemi top, hemi bottom, pixels 0..3) of the steady, binned
 * (bin b) and tail rows of the set, from its value array. */
typedef struct views {
  double steady[VALUES], tail[VALUES];
  const double *bins[VALUES]; /* stride 1 per bin for hemi; see bin_at */
  int32_t bin_stride[VALUES];
} views_t;

static views_t view(const hetinv_measurements_t *set, const double *x) {
  views_t w;
  int v = 0;
  for (int sensor = 0; sensor < 3; ++sensor) {
    size_t off[3];
    int32_t pixels = 0, bins = 0;
    for (int k = 0; k < 3; ++k) {
      assert_ok(hetinv_measurements_row_layout(set, 3 * sensor + k, &off[k], &pixels, &bins));
    }
    for (int32_t p = 0; p < pixels; ++p, ++v) {
      w.steady[v] = x[off[0] + (size_t)p];
      w.tail[v] = x[off[2] + (size_t)p];
      w.bins[v] = x + off[1] + (size_t)p; /* value (pixel p, bin b) at b·pixels + p */
      w.bin_stride[v] = pixels;
    }
  }
  assert_int_equal(v, VALUES);
  return w;
}

static const char *value_name(int v) {
  static const char *names[VALUES] = {"hemi_top_region", "hemi_bottom", "pixel0", "pixel1",
                                      "pixel2", "pixel3"};
  return names[v];
}

/* 1. Σ bins + catch-all = steady, for the same photons. Both sides sum the
 * same n contributions, grouped differently, so they differ by rounding
 * only: for a hemispherical detector (one contribution per photon, n ≤ N =
 * 1e5) by at most 2nε = 2.2e-11 of the total; for a pixel (one contribution
 * per connection chain that reaches it, n ≲ 1e8) by ~sqrt(n)·ε ≈ 1e-12 in
 * practice (measured: 1e-16 to 1e-15). The tolerance, 1e-9 of the total, is
 * far above that and below the relative size ~1/n ≳ 1e-8 of a typical
 * contribution, so one that fell into no bin or into two bins would show. */
static void box_bins_partition_the_steady_state(void **state) {
  (void)state;
  scene_t s = make_scene();
  size_t count = hetinv_measurements_value_count(s.set);
  double *x = malloc(count * sizeof *x), *se = malloc(count * sizeof *se);
  assert_true(x != NULL && se != NULL);
  hetinv_estimator_t *est = val_estimator(s.ctx, 1e5);
  assert_ok(hetinv_estimator_render(est, s.medium, s.set, x, se, NULL, count));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)st.photons, st.seconds);
  views_t w = view(s.set, x), wse = view(s.set, se);
  int failures = 0;
  for (int v = 0; v < VALUES; ++v) {
    double sum = 0.0;
    for (int b = 0; b < BINS; ++b) sum += w.bins[v][(size_t)b * (size_t)w.bin_stride[v]];
    char what[64];
    snprintf(what, sizeof what, "bins_plus_tail_equal_steady_%s", value_name(v));
    failures += !val_check_exact("PL1", what, w.steady[v], sum + w.tail[v], 1e-9 * w.steady[v], seed);
    snprintf(what, sizeof what, "tail_beyond_tau_max_%s", value_name(v));
    failures += !val_check_exact("PL1", what, 0.0, w.tail[v], 1e-3 * wse.steady[v], seed);
  }
  hetinv_estimator_destroy(&est);
  free(x);
  free(se);
  free_scene(&s);
  val_assert_all_passed(failures);
}

/* 2. Σ_b I_b(σa) e^{-δτ_b} = I(σa + δ). The reweighted sums of different
 * bins share photons (a photon's connections land in many bins), so their
 * error bar is the spread over REPLICAS independent renders (different
 * streams) of N/REPLICAS photons each; the threshold is Student's t with
 * REPLICAS - 1 degrees of freedom. The render of σa + δ is independent
 * (another stream) with its own batch error bars. */
static void reweighting_by_pathlength_matches_added_absorption(void **state) {
  (void)state;
  scene_t s = make_scene();
  size_t count = hetinv_measurements_value_count(s.set);
  double *x = malloc(count * sizeof *x);
  assert_non_null(x);
  double factor[BINS];
  for (int b = 0; b < BINS; ++b) factor[b] = exp(-delta * (b + 0.5) * bin_w);
  double sum[VALUES] = {0}, sq[VALUES] = {0}, seconds = 0.0;
  for (int r = 0; r < REPLICAS; ++r) {
    hetinv_estimator_t *est = val_estimator(s.ctx, 8e5 / REPLICAS);
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, 16));
    assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 1 + r));
    assert_ok(hetinv_estimator_render(est, s.medium, s.set, x, NULL, NULL, count));
    hetinv_render_stats_t st = {.size = sizeof st};
    assert_ok(hetinv_estimator_get_stats(est, &st));
    seconds += st.seconds;
    hetinv_estimator_destroy(&est);
    views_t w = view(s.set, x);
    for (int v = 0; v < VALUES; ++v) {
      double y = 0.0;
      for (int b = 0; b < BINS; ++b) y += factor[b] * w.bins[v][(size_t)b * (size_t)w.bin_stride[v]];
      sum[v] += y;
      sq[v] += y * y;
    }
  }
  printf("render: %d replicas in %.2f s\n", REPLICAS, seconds);

  double ref[VALUES], ref_se[VALUES];
  hetinv_estimator_t *est = val_estimator(s.ctx, 4e5);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, 1000));
  assert_ok(hetinv_estimator_render(est, s.absorbing, s.plain, ref, ref_se, NULL, VALUES));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)st.photons, st.seconds);
  hetinv_estimator_destroy(&est);

  /* The binning bound e^{δw/2} - 1 as the reweighted side's "reference
   * precision", in quadrature with the render of σa + δ. */
  double bin_rel = expm1(0.5 * delta * bin_w);
  double t_max = val_t_max(REPLICAS - 1, COMPARISONS);
  int failures = 0;
  for (int v = 0; v < VALUES; ++v) {
    double mean = sum[v] / REPLICAS;
    double var = (sq[v] - sum[v] * mean) / (REPLICAS - 1);
    double se_mean = sqrt(var > 0.0 ? var / REPLICAS : 0.0);
    double other = sqrt(ref_se[v] * ref_se[v] + bin_rel * bin_rel * mean * mean);
    char what[64];
    snprintf(what, sizeof what, "reweighted_delta%.2f_%s", delta, value_name(v));
    failures += !val_compare("PL2", what, ref[v], other, mean, se_mean, t_max, seed);
  }
  free(x);
  free_scene(&s);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(box_bins_partition_the_steady_state),
      cmocka_unit_test(reweighting_by_pathlength_matches_added_absorption),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
