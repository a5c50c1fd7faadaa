/* Unscattered light against closed forms: media with σs = 0, where every
 * photon travels in straight lines between Fresnel events, so the exact
 * answers are Beer–Lambert attenuation, Fresnel reflectance and geometric
 * series of internal reflections, integrated over the source's directions
 * where needed (by Simpson's rule on a smooth integrand, to ~1e-12, far
 * below every error bar).
 *
 * This pins down, against numbers computed here from first principles:
 * the diffuse source's cosine-weighted directions, Fresnel reflectance and
 * refraction at oblique incidence on entry and exit, the pathlength of each
 * pass through the slab (box and Gaussian windows), the ballistic channel of
 * hemispherical detectors and of orthographic pixels, the pixel layout and
 * face coordinates (u, v) of every face, the spatial pattern of an area
 * source, and the weights of a combination of pencil beams.
 *
 * The test's own Fresnel function is first checked against the reference
 * values of scottprahl/iadpython tests/test_fresnel.py, to half a unit of
 * their last digit. */
#include <float.h>
#include <math.h>

#include "validation.h"

/* 1 (diffuse, η = 1) + 3 (diffuse, η = 1.5) + 6 (oblique beam) + 6 (pixel
 * layout) + 4 (pattern) + 3 (combination). */
#define COMPARISONS 23

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eed0b01)

/* Unpolarised Fresnel reflectance for incidence cosine c on the side of
 * index n1, into index n2; 1 beyond the critical angle. */
static double fresnel(double c, double n1, double n2) {
  double s2 = (n1 / n2) * (n1 / n2) * (1.0 - c * c);
  if (s2 >= 1.0) return 1.0;
  double ct = sqrt(1.0 - s2);
  double rs = (n1 * c - n2 * ct) / (n1 * c + n2 * ct);
  double rp = (n2 * c - n1 * ct) / (n2 * c + n1 * ct);
  return 0.5 * (rs * rs + rp * rp);
}

/* Cosine inside (index n) of light refracted from air at cosine mu. */
static double refracted_cos(double mu, double n) { return sqrt(1.0 - (1.0 - mu * mu) / (n * n)); }

/* ∫_0^1 f(μ) dμ by composite Simpson on 20000 intervals. */
static double integrate(double (*f)(double, const void *), const void *ctx) {
  const int n = 20000;
  double h = 1.0 / n, sum = f(0.0, ctx) + f(1.0, ctx);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4.0 : 2.0) * f(i * h, ctx);
  return sum * h / 3.0;
}

static void own_fresnel_matches_reference_values(void **state) {
  (void)state;
  int failures = 0;
  failures += !val_check_exact("U0", "fresnel_air_to_1.5_mu1.0", 0.04, fresnel(1.0, 1.0, 1.5), 1e-12, seed);
  failures += !val_check_exact("U0", "fresnel_air_to_1.5_mu0.5", 0.0891867128, fresnel(0.5, 1.0, 1.5), 5e-11, seed);
  failures += !val_check_exact("U0", "fresnel_air_to_1.5_mu0.2", 0.338894, fresnel(0.2, 1.0, 1.5), 5e-7, seed);
  failures += !val_check_exact("U0", "fresnel_1.5_to_air_mu0.8", 0.11414110022, fresnel(0.8, 1.5, 1.0), 5e-12, seed);
  failures += !val_check_exact("U0", "refracted_cos_air_to_1.5_mu0.5", 0.81649658, refracted_cos(0.5, 1.5), 5e-9, seed);
  failures += !val_check_exact("U0", "fresnel_beyond_critical", 1.0, fresnel(0.745, 1.5, 1.0), 0.0, seed);
  val_assert_all_passed(failures);
}

/* A slab of thickness d (along z), 200·d wide, σa only, indices eta / 1. */
static hetinv_medium_t *absorbing_slab(hetinv_context_t *ctx, double d, double sigma_a, double eta) {
  double half = 100.0 * d;
  return val_medium(ctx, (double[]){-half, -half, 0.0}, (double[]){half, half, d}, (int32_t[]){1, 1, 1},
                    sigma_a, 0.0, 0.0, eta, 1.0, 1);
}

typedef struct slab_params {
  double tau, eta;
} slab_params_t;

/* Per unit cosine-weighted direction 2μ dμ: transmitted, reflected (after
 * entering) and specular fractions, and the specular's square. */
static double transmitted_at(double mu, const void *p_) {
  const slab_params_t *p = p_;
  double R = fresnel(mu, 1.0, p->eta), a = p->tau / refracted_cos(mu, p->eta);
  return 2.0 * mu * (1.0 - R) * (1.0 - R) * exp(-a) / (1.0 - R * R * exp(-2.0 * a));
}
static double reflected_at(double mu, const void *p_) {
  const slab_params_t *p = p_;
  double R = fresnel(mu, 1.0, p->eta), a = p->tau / refracted_cos(mu, p->eta);
  return 2.0 * mu * (1.0 - R) * (1.0 - R) * R * exp(-2.0 * a) / (1.0 - R * R * exp(-2.0 * a));
}
static double specular_at(double mu, const void *p_) {
  const slab_params_t *p = p_;
  return 2.0 * mu * fresnel(mu, 1.0, p->eta);
}
static double specular_sq_at(double mu, const void *p_) {
  const slab_params_t *p = p_;
  double R = fresnel(mu, 1.0, p->eta);
  return 2.0 * mu * R * R;
}

typedef struct slab_render {
  double top, top_se, bottom, bottom_se, bottom_ballistic;
  hetinv_render_stats_t stats;
} slab_render_t;

/* Hemispherical detectors over the whole top and bottom faces. */
static slab_render_t render_slab(hetinv_context_t *ctx, hetinv_medium_t *m, hetinv_emitter_t *e,
                                 double full_photons) {
  hetinv_sensor_t *top = NULL, *bottom = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &top));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &bottom));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, e, top, steady, NULL));
  assert_ok(hetinv_measurements_add(set, e, bottom, steady, NULL));
  hetinv_estimator_t *est = val_estimator(ctx, full_photons);
  double v[2], se[2], b[2];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, b, 2));
  slab_render_t r = {v[0], se[0], v[1], se[1], b[1], {.size = sizeof r.stats}};
  assert_ok(hetinv_estimator_get_stats(est, &r.stats));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)r.stats.photons, r.stats.seconds);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&top);
  hetinv_sensor_destroy(&bottom);
  return r;
}

/* Diffuse source, η = 1: T = 2∫ μ e^{-τ/μ} dμ = 2 E3(τ); nothing comes back. */
static void diffuse_source_through_absorber_matches_2E3(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  const double d = 1.0, sigma_a = 0.5;
  hetinv_medium_t *m = absorbing_slab(ctx, d, sigma_a, 1.0);
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MAX, (double[]){0.0, 0.0}, &e));
  slab_render_t r = render_slab(ctx, m, e, 8e6);
  slab_params_t p = {sigma_a * d, 1.0};
  double T = integrate(transmitted_at, &p);
  int failures = 0;
  failures += !val_compare("U1", "diffuse_T_2E3", T, 0.0, r.bottom, r.bottom_se, val_z_max(COMPARISONS), seed);
  failures += !val_check_exact("U1", "diffuse_top", 0.0, r.top, 0.0, seed);
  failures += !val_check_exact("U1", "diffuse_T_all_ballistic", r.bottom, r.bottom_ballistic, 0.0, seed);
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

/* Diffuse source, η = 1.5: specular 2∫Rμdμ, and transmission and
 * reflection as geometric series of internal reflections per direction. */
static void diffuse_source_through_refractive_absorber_matches_series(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  const double d = 1.0, sigma_a = 0.5, eta = 1.5;
  hetinv_medium_t *m = absorbing_slab(ctx, d, sigma_a, eta);
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MAX, (double[]){0.0, 0.0}, &e));
  slab_render_t r = render_slab(ctx, m, e, 8e6);
  slab_params_t p = {sigma_a * d, eta};
  double T = integrate(transmitted_at, &p), R = integrate(reflected_at, &p);
  double S = integrate(specular_at, &p), S2 = integrate(specular_sq_at, &p);
  /* The specular statistic is the mean of R(μ) over the photons' μ. */
  double S_se = sqrt((S2 - S * S) / (double)r.stats.photons);
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  failures += !val_compare("U2", "diffuse_specular", S, 0.0, r.stats.specular, S_se, z_max, seed);
  failures += !val_compare("U2", "diffuse_T", T, 0.0, r.bottom, r.bottom_se, z_max, seed);
  failures += !val_compare("U2", "diffuse_R_after_entry", R, 0.0, r.top, r.top_se, z_max, seed);
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

/* Pencil beam at μ0 = 0.8 into a 1 mm slab with η = 1.5. Inside it travels
 * at μ' = sqrt(1 - 0.36/2.25); pass k (k = 0, 1, ...) leaves the bottom
 * after τ_k = (2k+1) d/μ' with T_k = (1-R)² R^{2k} e^{-(2k+1)a}, a = σa d/μ',
 * and the top after 2k d/μ' (k ≥ 1) with (1-R)² R^{2k-1} e^{-2ka}. Pass 0
 * leaves the bottom along the beam's own direction, d·tanθ' = 0.4364 mm
 * beyond the entry point; pass 1 another 0.873 mm further on. */
static void oblique_beam_through_refractive_absorber_matches_series(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  const double d = 1.0, sigma_a = 0.5, eta = 1.5, mu0 = 0.8;
  hetinv_medium_t *m = absorbing_slab(ctx, d, sigma_a, eta);
  const double dir[3] = {0.6, 0.0, -0.8};
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){-0.6, 0.0, d + 0.8}, dir, &e)); /* enters at (0, 0) */
  double R = fresnel(mu0, 1.0, eta), mu_in = refracted_cos(mu0, eta), a = sigma_a * d / mu_in;
  double T0 = (1 - R) * (1 - R) * exp(-a), T1 = T0 * R * R * exp(-2 * a);
  double T = T0 / (1 - R * R * exp(-2 * a)), Rt = T0 * R * exp(-a) / (1 - R * R * exp(-2 * a));
  double tau0 = d / mu_in, tau1 = 3 * d / mu_in, shift = d * sqrt(1 - mu_in * mu_in) / mu_in;

  hetinv_sensor_t *top = NULL, *bottom = NULL, *ortho = NULL;
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MAX, NULL, NULL, &top));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, NULL, NULL, &bottom));
  /* 5 × 4 pixels of 0.25 mm; pass 0 leaves at (shift, 0): pixel (2, 1). */
  const double px = 0.25, origin[2] = {shift - 2.4 * px, -1.5 * px};
  assert_ok(hetinv_sensor_create_orthographic(m, HETINV_FACE_Z_MIN, dir, origin, (double[]){px, px},
                                              5, 4, &ortho));
  hetinv_pathlength_t *steady = NULL, *box = NULL, *gauss = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_BOX, 2, (double[]){tau0, tau1}, 0.05, &box));
  const double gc = tau0 + 0.05, gw = 0.1;
  assert_ok(hetinv_pathlength_create_bins(ctx, HETINV_WINDOW_GAUSSIAN, 1, &gc, gw, &gauss));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, e, top, steady, NULL));     /* 0 */
  assert_ok(hetinv_measurements_add(set, e, bottom, steady, NULL));  /* 1 */
  assert_ok(hetinv_measurements_add(set, e, bottom, box, NULL));     /* 2, 3 */
  assert_ok(hetinv_measurements_add(set, e, bottom, gauss, NULL));   /* 4 */
  assert_ok(hetinv_measurements_add(set, e, ortho, steady, NULL));   /* 5 .. 24 */
  hetinv_estimator_t *est = val_estimator(ctx, 1.6e7);
  double v[25], se[25], b[25];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, b, 25));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  printf("render: %llu photons in %.2f s\n", (unsigned long long)st.photons, st.seconds);
  double n = (double)st.photons, z_max = val_z_max(COMPARISONS);

  int failures = 0;
  /* Every photon reflects R at the first surface. */
  failures += !val_check_exact("U3", "beam_specular", R, st.specular, n * DBL_EPSILON * R, seed);
  failures += !val_compare("U3", "beam_T", T, 0.0, v[1], se[1], z_max, seed);
  failures += !val_compare("U3", "beam_R_after_entry", Rt, 0.0, v[0], se[0], z_max, seed);
  failures += !val_compare("U3", "beam_T_box_bin_pass0", T0, 0.0, v[2], se[2], z_max, seed);
  failures += !val_compare("U3", "beam_T_box_bin_pass1", T1, 0.0, v[3], se[3], z_max, seed);
  double g0 = exp(-0.5 * (tau0 - gc) * (tau0 - gc) / (gw * gw));
  double g1 = exp(-0.5 * (tau1 - gc) * (tau1 - gc) / (gw * gw));
  failures += !val_compare("U3", "beam_T_gaussian_window", T0 * g0 + T1 * g1, 0.0, v[4], se[4], z_max, seed);
  failures += !val_check_exact("U3", "beam_T_all_ballistic", v[1], b[1], 0.0, seed);
  /* Orthographic: no scattering, so no values; the ballistic channel holds
   * the power per area of pass 0 in pixel (2, 1) only. A photon scores
   * (1-R)/A with probability q = (1-R) e^{-a}. */
  double A = px * px, q = (1 - R) * exp(-a);
  int lit = 1 * 5 + 2, others_zero = 1;
  for (int k = 0; k < 20; ++k) {
    failures += !(v[5 + k] == 0.0);
    if (k != lit) others_zero = others_zero && b[5 + k] == 0.0;
  }
  failures += !val_check_exact("U3", "beam_ortho_unlit_pixels_ballistic", 0.0, others_zero ? 0.0 : 1.0, 0.0, seed);
  failures += !val_compare("U3", "beam_ortho_ballistic_pixel_2_1", T0 / A, 0.0, b[5 + lit],
                           (1 - R) / A * sqrt(q * (1 - q) / n), z_max, seed);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_pathlength_destroy(&box);
  hetinv_pathlength_destroy(&gauss);
  hetinv_sensor_destroy(&top);
  hetinv_sensor_destroy(&bottom);
  hetinv_sensor_destroy(&ortho);
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

/* Pixel (i, j), value j·width + i, covers [origin + i·size] along u and
 * [origin + j·size] along v, with (u, v) = (y, z) on x faces, (x, z) on y
 * faces, (x, y) on z faces. Six beams cross a 1 mm absorbing cube along
 * ±x, ±y, ±z at normal incidence (η = 1); each exit face has a 4 × 6
 * sensor looking along the beam, which must light exactly the pixel under
 * the exit point, with e^{-σa·1mm}/A of ballistic power per area. */
static void pixels_follow_each_faces_coordinates(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  const double sigma_a = 0.7;
  hetinv_medium_t *m = val_medium(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){1, 1, 1},
                                  sigma_a, 0.0, 0.0, 1.0, 1.0, 1);
  const double size[2] = {0.2, 0.15}, origin[2] = {0.05, 0.02};
  const int width = 4, height = 6;
  hetinv_emitter_t *e[6];
  hetinv_sensor_t *s[6];
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  int expect[6];
  for (int f = 0; f < 6; ++f) {
    int axis = f / 2, au = axis == 0 ? 1 : 0, av = axis == 2 ? 1 : 2;
    double sign = (f & 1) ? 1.0 : -1.0; /* exit face f: travel along sign·axis */
    /* A different exit point per face: (u, v) = (0.05 + 0.2·(i + 0.5), 0.02 + 0.15·(j + 0.3)). */
    int i = f % 4, j = (f + 2) % 6;
    double u = origin[0] + size[0] * (i + 0.5), v = origin[1] + size[1] * (j + 0.3);
    double o[3], d[3] = {0, 0, 0};
    o[axis] = sign > 0 ? -1.0 : 2.0;
    o[au] = u;
    o[av] = v;
    d[axis] = sign;
    assert_ok(hetinv_emitter_create_ideal(m, o, d, &e[f]));
    assert_ok(hetinv_sensor_create_orthographic(m, f, d, origin, size, width, height, &s[f]));
    assert_ok(hetinv_measurements_add(set, e[f], s[f], steady, NULL));
    expect[f] = j * width + i;
  }
  hetinv_estimator_t *est = val_estimator(ctx, 1e6);
  double v[6 * 24], b[6 * 24];
  assert_ok(hetinv_estimator_render(est, m, set, v, NULL, b, 6 * 24));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  double n = (double)st.photons / 6.0, p = exp(-sigma_a), A = size[0] * size[1];
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  for (int f = 0; f < 6; ++f) {
    int stray = 0;
    for (int k = 0; k < 24; ++k) {
      failures += !(v[24 * f + k] == 0.0);
      if (k != expect[f]) stray += b[24 * f + k] != 0.0;
    }
    char what[64];
    snprintf(what, sizeof what, "face%d_pixel%d_ballistic_only_lit_pixel", f, expect[f]);
    failures += !val_check_exact("U4", what, 0.0, (double)stray, 0.0, seed);
    snprintf(what, sizeof what, "face%d_pixel%d_ballistic", f, expect[f]);
    failures += !val_compare("U4", what, p / A, 0.0, b[24 * f + expect[f]], sqrt(p * (1 - p) / n) / A,
                             z_max, seed);
  }
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  for (int f = 0; f < 6; ++f) {
    hetinv_sensor_destroy(&s[f]);
    hetinv_emitter_destroy(&e[f]);
  }
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

/* An area source's pattern spreads its power in proportion to the weights,
 * u fastest, row 0 at v = rect_min[1]. A 2 × 2 pattern (1, 2, 3, 4) on the
 * y = 0 face (u = x, v = z) of an absorbing cube, shining along +y; a
 * hemispherical detector on the far face under each cell gets
 * e^{-σa} w / 10. */
static void area_pattern_spreads_power_by_weight(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  const double sigma_a = 0.4;
  hetinv_medium_t *m = val_medium(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){1, 1, 1},
                                  sigma_a, 0.0, 0.0, 1.0, 1.0, 1);
  const double lo[2] = {0.2, 0.1}, hi[2] = {0.8, 0.9}, w[4] = {1, 2, 3, 4};
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_area(m, HETINV_FACE_Y_MIN, (double[]){0, 1, 0}, lo, hi, 2, 2, w, &e));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  hetinv_sensor_t *s[4];
  for (int c = 0; c < 4; ++c) {
    int cx = c % 2, cy = c / 2;
    double du = (hi[0] - lo[0]) / 2, dv = (hi[1] - lo[1]) / 2;
    double rlo[2] = {lo[0] + cx * du, lo[1] + cy * dv}, rhi[2] = {rlo[0] + du, rlo[1] + dv};
    assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Y_MAX, rlo, rhi, &s[c]));
    assert_ok(hetinv_measurements_add(set, e, s[c], steady, NULL));
  }
  hetinv_estimator_t *est = val_estimator(ctx, 4e6);
  double v[4], se[4];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, NULL, 4));
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  for (int c = 0; c < 4; ++c) {
    char what[48];
    snprintf(what, sizeof what, "pattern_cell%d_weight%.0f", c, w[c]);
    failures += !val_compare("U5", what, exp(-sigma_a) * w[c] / 10.0, 0.0, v[c], se[c], z_max, seed);
  }
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  for (int c = 0; c < 4; ++c) hetinv_sensor_destroy(&s[c]);
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

/* A combination of pencil beams with weights 0.5 and 1.5 emits power 2:
 * its values are the weighted sum of its beams' (linearity), while the
 * statistics stay fractions of the emitted power (they add up to 1). */
static void combination_values_are_weighted_sums(void **state) {
  (void)state;
  hetinv_context_t *ctx = val_context(seed, 1);
  const double sigma_a = 0.4;
  hetinv_medium_t *m = val_medium(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){1, 1, 1},
                                  sigma_a, 0.0, 0.0, 1.0, 1.0, 1);
  const double origins[6] = {0.3, 0.3, 2.0, 0.7, 0.6, 2.0}, dirs[6] = {0, 0, -1, 0, 0, -1};
  const double weights[2] = {0.5, 1.5};
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_combination(m, 2, origins, dirs, weights, &e));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  hetinv_sensor_t *s[2];
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, (double[]){0, 0}, (double[]){0.5, 1}, &s[0]));
  assert_ok(hetinv_sensor_create_hemispherical(m, HETINV_FACE_Z_MIN, (double[]){0.5, 0}, (double[]){1, 1}, &s[1]));
  for (int i = 0; i < 2; ++i) assert_ok(hetinv_measurements_add(set, e, s[i], steady, NULL));
  hetinv_estimator_t *est = val_estimator(ctx, 4e6);
  double v[2], se[2];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, NULL, 2));
  hetinv_render_stats_t st = {.size = sizeof st};
  assert_ok(hetinv_estimator_get_stats(est, &st));
  double p = exp(-sigma_a), n = (double)st.photons, z_max = val_z_max(COMPARISONS);
  int failures = 0;
  failures += !val_compare("U6", "combination_beam0_weight0.5", 0.5 * p, 0.0, v[0], se[0], z_max, seed);
  failures += !val_compare("U6", "combination_beam1_weight1.5", 1.5 * p, 0.0, v[1], se[1], z_max, seed);
  /* Fraction of the power leaving through the bottom: every photon does so
   * with probability e^{-σa}, whichever beam it comes from. */
  failures += !val_compare("U6", "combination_stats_escaped_bottom_fraction", p, 0.0,
                           st.escaped[HETINV_FACE_Z_MIN], sqrt(p * (1 - p) / n), z_max, seed);
  double sum = st.specular + st.absorbed + st.truncated;
  for (int f = 0; f < 6; ++f) sum += st.escaped[f];
  failures += !val_check_exact("U6", "combination_stats_balance", 1.0, sum, 1e-12, seed);
  hetinv_estimator_destroy(&est);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  for (int i = 0; i < 2; ++i) hetinv_sensor_destroy(&s[i]);
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(own_fresnel_matches_reference_values),
      cmocka_unit_test(diffuse_source_through_absorber_matches_2E3),
      cmocka_unit_test(diffuse_source_through_refractive_absorber_matches_series),
      cmocka_unit_test(oblique_beam_through_refractive_absorber_matches_series),
      cmocka_unit_test(pixels_follow_each_faces_coordinates),
      cmocka_unit_test(area_pattern_spreads_power_by_weight),
      cmocka_unit_test(combination_values_are_weighted_sums),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
