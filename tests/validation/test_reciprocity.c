/* Reciprocity of light transport (Helmholtz), in the form the API can
 * express exactly.
 *
 * Let S(x_o, ω_o ← x_i, ω_i) be the radiance leaving the boundary at x_o
 * along ω_o per unit power entering at x_i along ω_i (directions of travel,
 * both points outside the medium, in the same outside index). Reciprocity:
 *   S(x_o, ω_o ← x_i, ω_i) = S(x_i, −ω_i ← x_o, −ω_o).
 * A collimated area source over a face rectangle R along ω_i spreads its
 * power 1 uniformly over R, and a one-pixel orthographic sensor over a face
 * rectangle P along ω_o averages the radiance over P, so
 *   forward = (1/|R||P|) ∫_P ∫_R S(x_o, ω_o ← x_i, ω_i) dx_i dx_o.
 * Swapping the rectangles and reversing the directions (source over P along
 * −ω_o, sensor over R along −ω_i) gives the same double integral of the
 * reciprocal S: the two values are equal exactly, for any rectangles, not
 * only in the limit of small pixels. (A hemispherical detector against a
 * diffuse point source would pair a point with an area, and be exact only
 * in the limit of a small region.)
 *
 * Each pair is compared on a small heterogeneous medium (anisotropic
 * Henyey–Greenstein g, which is reciprocal because it depends on ω·ω'
 * only), index-matched as the brief asks, and also with η = 1.3 inside:
 * with both ends outside in the same index, the Fresnel transmittances
 * (symmetric in the two sides) and the η² radiance factors (which cancel
 * between entry and exit) keep S reciprocal, and the forward and reverse
 * values reach the boundary in different ways (random Fresnel choices on
 * the way in, deterministic specular chains of the connections on the way
 * out). Forward and reverse rows have distinct emitters, so their photons
 * are independent and the errors add in quadrature. */
#include <math.h>

#include "validation.h"

#define PAIRS 4
/* Each pair index-matched, with η = 1.3 inside and with η = 1.4 outside;
 * and the grazing-exit pair. */
#define COMPARISONS (3 * PAIRS + 1)

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed005d)

static const double box_lo[3] = {0.0, 0.0, 0.0}, box_hi[3] = {3.0, 3.0, 1.5};
static const val_ranges_t ranges = {{0.2, 0.6}, {1.0, 4.0}, {0.0, 0.7}};

typedef struct end {
  hetinv_face_t face;
  double lo[2], hi[2];
  double dir[3]; /* travel direction: into the face (entry) or out of it (exit) */
} end_t;

typedef struct pair {
  const char *name;
  end_t in, out;
} pair_t;

/* x_i on the top face; x_o on the top face (reflection), a side face, and
 * the bottom face (transmission); and from one side face to another. Every
 * direction is within 45° of its face's normal, so that light from inside
 * can leave along it even when the outside index is the higher (1.4). */
static const pair_t pairs[PAIRS] = {
    {"top_to_top", {HETINV_FACE_Z_MAX, {0.3, 0.5}, {1.0, 1.2}, {0.4, 0.2, -1.0}},
     {HETINV_FACE_Z_MAX, {1.8, 1.4}, {2.6, 2.2}, {0.3, -0.5, 1.0}}},
    {"top_to_side", {HETINV_FACE_Z_MAX, {1.6, 0.9}, {2.4, 1.9}, {0.5, -0.1, -1.0}},
     {HETINV_FACE_X_MAX, {1.0, 0.3}, {2.0, 1.2}, {1.0, 0.3, -0.2}}},
    {"top_to_bottom", {HETINV_FACE_Z_MAX, {0.8, 0.8}, {1.8, 1.6}, {-0.2, 0.3, -1.0}},
     {HETINV_FACE_Z_MIN, {1.2, 1.0}, {2.2, 2.1}, {-0.2, 0.4, -1.0}}},
    {"side_to_side", {HETINV_FACE_X_MIN, {0.5, 0.2}, {1.5, 0.9}, {1.0, 0.3, 0.2}},
     {HETINV_FACE_Y_MAX, {1.2, 0.6}, {2.4, 1.3}, {-0.3, 1.0, 0.1}}},
};

/* Area source over `from` along from->dir; sensor over `to` along to->dir. */
static void add_row(hetinv_medium_t *m, hetinv_measurements_t *set, hetinv_pathlength_t *steady,
                    const end_t *from, const end_t *to, hetinv_emitter_t **e, hetinv_sensor_t **s) {
  assert_ok(hetinv_emitter_create_area(m, from->face, from->dir, from->lo, from->hi, 1, 1, NULL, e));
  double size[2] = {to->hi[0] - to->lo[0], to->hi[1] - to->lo[1]};
  assert_ok(hetinv_sensor_create_orthographic(m, to->face, to->dir, to->lo, size, 1, 1, s));
  assert_ok(hetinv_measurements_add(set, *e, *s, steady, NULL));
}

static int compare_pairs(const char *case_id, double eta, double eta_out, double full_photons) {
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *m = val_heterogeneous(ctx, box_lo, box_hi, (int32_t[]){3, 3, 3}, &ranges, seed, eta, eta_out);
  assert_ok(hetinv_medium_commit(m));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  hetinv_emitter_t *e[2 * PAIRS];
  hetinv_sensor_t *s[2 * PAIRS];
  for (int p = 0; p < PAIRS; ++p) {
    const end_t *a = &pairs[p].in, *b = &pairs[p].out;
    /* The reversed ends: B lit along −ω_o, A seen along −ω_i. */
    end_t rb = *b, ra = *a;
    for (int k = 0; k < 3; ++k) {
      rb.dir[k] = -b->dir[k];
      ra.dir[k] = -a->dir[k];
    }
    add_row(m, set, steady, a, b, &e[2 * p], &s[2 * p]);
    add_row(m, set, steady, &rb, &ra, &e[2 * p + 1], &s[2 * p + 1]);
  }
  hetinv_estimator_t *est = val_estimator(ctx, full_photons);
  double v[2 * PAIRS], se[2 * PAIRS];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, NULL, 2 * PAIRS));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)st.photons, st.seconds);
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  for (int p = 0; p < PAIRS; ++p) {
    char what[64];
    snprintf(what, sizeof what, "reverse_vs_forward_%s", pairs[p].name);
    /* The forward value as the "reference", with its error bar. */
    failures += !val_compare(case_id, what, v[2 * p], se[2 * p], v[2 * p + 1], se[2 * p + 1], z_max, seed);
  }
  hetinv_estimator_destroy(&est);
  for (int i = 0; i < 2 * PAIRS; ++i) {
    hetinv_emitter_destroy(&e[i]);
    hetinv_sensor_destroy(&s[i]);
  }
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return failures;
}

static void transport_is_reciprocal_index_matched(void **state) {
  (void)state;
  val_assert_all_passed(compare_pairs("RC_eta1.0", 1.0, 1.0, 4e5));
}

static void transport_is_reciprocal_through_a_refractive_boundary(void **state) {
  (void)state;
  val_assert_all_passed(compare_pairs("RC_eta1.3", 1.3, 1.0, 6e4));
}

/* A medium of lower index than its surroundings (η = 1, η_out = 1.4):
 * light from outside can be totally reflected on the way in, and light
 * leaves within 45.6° of the normal only. */
static void transport_is_reciprocal_into_a_lower_index(void **state) {
  (void)state;
  val_assert_all_passed(compare_pairs("RC_eta_out1.4", 1.0, 1.4, 6e4));
}

/* Grazing exit from a narrow, tall, weakly scattering medium with η = 1.3:
 * 0.2 × 0.2 × 3 mm, σt ≈ 0.13/mm. Forward: light enters the top face near
 * the normal and is seen leaving the top face at μ = 0.01 (azimuth 45°).
 * Its interior direction (0.544, 0.544, 0.639) is totally reflected by the
 * four side faces (|cos| = 0.544 < cos θc = 0.6390), and the top and bottom
 * faces reflect R = 0.937 of it. A connection's specular chain therefore
 * bounces ~26 times between side faces per crossing of the height (4.7 mm
 * of path), and its throughput falls below 1e-7 of its start only after
 * ~25 crossings (Fresnel and attenuation together), i.e. ~650 bounces.
 * Reverse: light enters at grazing incidence and is seen leaving near the
 * normal, where chains die within a few bounces. (The same pair in a 3 mm
 * wide box, with few side bounces per crossing, agrees.) */
static void transport_is_reciprocal_at_grazing_exit_from_a_narrow_medium(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  const val_ranges_t thin = {{0.005, 0.02}, {0.05, 0.2}, {0.0, 0.5}};
  hetinv_medium_t *m = val_heterogeneous(ctx, (double[]){0, 0, 0}, (double[]){0.2, 0.2, 3.0},
                                         (int32_t[]){1, 1, 3}, &thin, seed, 1.3, 1.0);
  assert_ok(hetinv_medium_commit(m));
  const double mu = 0.01, st = sqrt(1.0 - mu * mu) * sqrt(0.5);
  const end_t in = {HETINV_FACE_Z_MAX, {0.0, 0.0}, {0.2, 0.2}, {0.1, 0.05, -1.0}};
  const end_t out = {HETINV_FACE_Z_MAX, {0.0, 0.0}, {0.2, 0.2}, {st, st, mu}};
  end_t rin = in, rout = out;
  for (int k = 0; k < 3; ++k) {
    rin.dir[k] = -in.dir[k];
    rout.dir[k] = -out.dir[k];
  }
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  hetinv_emitter_t *e[2];
  hetinv_sensor_t *s[2];
  add_row(m, set, steady, &in, &out, &e[0], &s[0]);
  add_row(m, set, steady, &rout, &rin, &e[1], &s[1]);
  hetinv_estimator_t *est = val_estimator(ctx, 2e5);
  double v[2], se[2];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, NULL, 2));
  hetinv_render_stats_t stats = {.size = sizeof stats};
  assert_ok(hetinv_estimator_get_stats(est, &stats));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)stats.photons, stats.seconds);
  int failures = !val_compare("RC_grazing", "reverse_vs_forward_mu0.01_narrow_box", v[0], se[0], v[1],
                              se[1], val_z_max(COMPARISONS), seed);
  hetinv_estimator_destroy(&est);
  for (int i = 0; i < 2; ++i) {
    hetinv_emitter_destroy(&e[i]);
    hetinv_sensor_destroy(&s[i]);
  }
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(transport_is_reciprocal_index_matched),
      cmocka_unit_test(transport_is_reciprocal_through_a_refractive_boundary),
      cmocka_unit_test(transport_is_reciprocal_into_a_lower_index),
      cmocka_unit_test(transport_is_reciprocal_at_grazing_exit_from_a_narrow_medium),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
