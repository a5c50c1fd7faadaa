/* The fiber probe (lib/sensors/fiber.c) against closed forms: a diffuse
 * (Lambertian) point source on the top face of a non-scattering absorbing
 * slab, and fibers on the bottom face, on the source's axis and off it.
 *
 * With σs = 0 every photon keeps its direction but for mirror reflections at
 * the two faces. A photon entering at outside cosine μ (cosine-weighted: 2μ dμ
 * per unit power, azimuth φ uniform) refracts to μ_i, then leaves the bottom
 * after 2k + 1 crossings (k = 0, 1, ...) with weight
 *   (1 − R)² R^{2k} e^{−(2k+1)σa d/μ_i},  R = R_Fresnel(μ),
 * at lateral distance ρ_k = (2k+1)·d·tan θ_i from the source along φ, and
 * along the outside angle θ_e = acos μ again (parallel faces, same indices).
 * A fiber of radius r centred at distance c from the source's axis accepts it
 * if η_out·sin θ_e ≤ NA and the point lies on its disk, which for given ρ is
 * a fraction of the azimuths in closed form:
 *   1 for ρ ≤ r − c, 0 for ρ ≥ r + c or ρ ≤ c − r, else acos((ρ² + c² − r²) / (2ρc))/π.
 * So the accepted power is a sum over k of 1D integrals over μ, integrated
 * here between the breakpoints of the indicator and of the disk fraction by
 * Simpson's rule (the fraction has square-root kinks at its ends, so the
 * rule converges as h^1.5: the reference's precision is taken as the
 * change from n to 2n intervals, and is far below the error bars).
 * ∂/∂σa of the same sum multiplies each term by −(2k+1)·d/μ_i: the
 * gradient pass's score of the fiber, against it.
 *
 * Two interfaces: air outside (η = 1.5 / 1) and water outside (η = 1.4 /
 * 1.33), so that an aperture compared with the inside angle, or with sin θ
 * alone, fails. The slab is 200·d wide: a path that reaches a side face and
 * comes back to a fiber travels more than 98·d, attenuated by e^{−49}. */
#include <math.h>
#include <stdlib.h>

#include "test_gradient_common.h"

/* 12 fiber values (6 per interface) + 2 gradients. */
#define COMPARISONS 14

static uint64_t seed; /* val_seed(SEED), set in main */
#define SEED UINT64_C(0x5eedf1be)

enum { FIBERS = 6 };

typedef struct fiber_case {
  double centre[2], radius, na;
} fiber_case_t;

typedef struct slab {
  double d, sigma_a, eta, eta_out;
} slab_t;

/* Unpolarised Fresnel reflectance for incidence cosine c on the side of
 * index n1, into index n2; 1 beyond the critical angle (as test_unscattered.c). */
static double fresnel(double c, double n1, double n2) {
  double s2 = (n1 / n2) * (n1 / n2) * (1.0 - c * c);
  if (s2 >= 1.0) return 1.0;
  double ct = sqrt(1.0 - s2);
  double rs = (n1 * c - n2 * ct) / (n1 * c + n2 * ct);
  double rp = (n2 * c - n1 * ct) / (n2 * c + n1 * ct);
  return 0.5 * (rs * rs + rp * rp);
}

/* Fraction of the circle of radius rho about the axis that lies on the disk
 * of radius r centred at distance c from it (closed). */
static double disk_fraction(double rho, double c, double r) {
  if (c == 0.0) return rho <= r ? 1.0 : 0.0;
  if (rho <= r - c) return 1.0;
  if (rho >= r + c || rho <= c - r) return 0.0;
  double x = (rho * rho + c * c - r * r) / (2.0 * rho * c);
  return acos(fmax(-1.0, fmin(1.0, x))) / VAL_PI;
}

typedef struct term {
  const slab_t *slab;
  const fiber_case_t *fiber;
  int k;            /* 2k + 1 crossings */
  int derivative;   /* 0: power; 1: ∂/∂σa */
} term_t;

static double term_at(double mu, const term_t *t) {
  const slab_t *s = t->slab;
  if (mu <= 0.0 || t->slab->eta_out * sqrt(1.0 - mu * mu) > t->fiber->na) return 0.0;
  double sin_i = s->eta_out / s->eta * sqrt(1.0 - mu * mu), mu_i = sqrt(1.0 - sin_i * sin_i);
  double crossings = 2.0 * t->k + 1.0, rho = crossings * s->d * sin_i / mu_i;
  double c = hypot(t->fiber->centre[0], t->fiber->centre[1]);
  double frac = disk_fraction(rho, c, t->fiber->radius);
  if (frac == 0.0) return 0.0;
  double R = fresnel(mu, s->eta_out, s->eta);
  double w = 2.0 * mu * (1.0 - R) * (1.0 - R) * pow(R, 2.0 * t->k) * exp(-crossings * s->sigma_a * s->d / mu_i);
  if (t->derivative) w *= -crossings * s->d / mu_i;
  return w * frac;
}

/* The outside cosine at which pass k lands at lateral distance rho; -1 if none. */
static double mu_at_distance(const slab_t *s, int k, double rho) {
  double t = rho / ((2.0 * k + 1.0) * s->d), sin_i = t / sqrt(1.0 + t * t);
  double sin_e = s->eta / s->eta_out * sin_i;
  return sin_e < 1.0 ? sqrt(1.0 - sin_e * sin_e) : -1.0;
}

static int compare_doubles(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* ∫_0^1 of the term over μ by composite Simpson on n intervals between each
 * pair of breakpoints. */
static double integrate_term(const term_t *t, int n) {
  double cuts[8];
  int m = 0;
  cuts[m++] = 0.0;
  cuts[m++] = 1.0;
  if (t->fiber->na < t->slab->eta_out) {
    double s = t->fiber->na / t->slab->eta_out;
    cuts[m++] = sqrt(1.0 - s * s);
  }
  double c = hypot(t->fiber->centre[0], t->fiber->centre[1]), r = t->fiber->radius;
  const double rhos[3] = {fabs(r - c), r + c, r};
  for (int i = 0; i < 3; ++i) {
    double mu = mu_at_distance(t->slab, t->k, rhos[i]);
    if (mu > 0.0 && mu < 1.0) cuts[m++] = mu;
  }
  qsort(cuts, (size_t)m, sizeof cuts[0], compare_doubles);
  double total = 0.0;
  for (int j = 0; j + 1 < m; ++j) {
    double a = cuts[j], b = cuts[j + 1], h = (b - a) / n;
    if (!(h > 0.0)) continue;
    /* Ends taken just inside (by far more than an ulp, far less than h), so
     * that an indicator's jump at a breakpoint counts on its own side. */
    double sum = term_at(a + 1e-9 * (b - a), t) + term_at(b - 1e-9 * (b - a), t);
    for (int i = 1; i < n; ++i) sum += (i % 2 ? 4.0 : 2.0) * term_at(a + i * h, t);
    total += sum * h / 3.0;
  }
  return total;
}

/* The accepted power (or its ∂/∂σa), summed over passes k until a bound on
 * the rest falls below 1e-17: with R ≤ 1 and 2μ(1 − R)² ≤ 2, pass k adds at
 * most 2·(2k+1)·(d/μ_i,min)·e^{−(2k+1)σa d}, μ_i,min the cosine of the
 * critical angle. (A pass's own integral may be 0 while later ones are not:
 * an off-axis disk that only wider passes reach.) *precision: the change
 * from n to 2n intervals. */
static double reference(const slab_t *s, const fiber_case_t *f, int derivative, double *precision) {
  double coarse = 0.0, fine = 0.0, sin_max = s->eta_out / s->eta, mu_i_min = sqrt(1.0 - sin_max * sin_max);
  for (int k = 0;; ++k) {
    double crossings = 2.0 * k + 1.0;
    if (2.0 * crossings * s->d / mu_i_min * exp(-crossings * s->sigma_a * s->d) < 1e-17) break;
    term_t t = {s, f, k, derivative};
    coarse += integrate_term(&t, 2000);
    fine += integrate_term(&t, 4000);
  }
  *precision = fabs(fine - coarse);
  return fine;
}

static hetinv_medium_t *absorbing_slab(hetinv_context_t *ctx, const slab_t *s) {
  double half = 100.0 * s->d;
  return val_medium(ctx, (double[]){-half, -half, 0.0}, (double[]){half, half, s->d}, (int32_t[]){1, 1, 1},
                    s->sigma_a, 0.0, 0.0, s->eta, s->eta_out, 1);
}

/* Renders the fibers under a diffuse source at the top face's centre,
 * compares each with its reference, and the σa gradient of the fibers
 * listed in `gradients` (-1 ends the list). Returns the failures. */
static int check_fibers(const char *case_id, const slab_t *s, const fiber_case_t fibers[FIBERS],
                        const int *gradients) {
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *m = absorbing_slab(ctx, s);
  hetinv_emitter_t *e = NULL;
  assert_ok(hetinv_emitter_create_diffuse(m, HETINV_FACE_Z_MAX, (double[]){0.0, 0.0}, &e));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  hetinv_sensor_t *sensors[FIBERS];
  for (int i = 0; i < FIBERS; ++i) {
    assert_ok(hetinv_sensor_create_fiber(m, HETINV_FACE_Z_MIN, fibers[i].centre, fibers[i].radius, fibers[i].na,
                                         &sensors[i]));
    assert_ok(hetinv_measurements_add(set, e, sensors[i], steady, NULL));
  }
  hetinv_estimator_t *est = val_estimator(ctx, 8e6);
  double v[FIBERS], se[FIBERS], ballistic[FIBERS];
  assert_ok(hetinv_estimator_render(est, m, set, v, se, ballistic, FIBERS));
  double z_max = val_z_max(COMPARISONS);
  int failures = 0;
  char quantity[96];
  for (int i = 0; i < FIBERS; ++i) {
    double precision, ref = reference(s, &fibers[i], 0, &precision);
    snprintf(quantity, sizeof quantity, "fiber_c%.2g,%.2g_r%.2g_NA%.3g", fibers[i].centre[0], fibers[i].centre[1],
             fibers[i].radius, fibers[i].na);
    failures += !val_compare(case_id, quantity, ref, precision, v[i], se[i], z_max, seed);
    /* Every photon is unscattered: the value is its ballistic part. */
    failures += !val_check_exact(case_id, "ballistic_is_the_value", v[i], ballistic[i], 0.0, seed);
  }
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, HETINV_FREE(HETINV_PARAM_SIGMA_A), &map));
  for (const int *g = gradients; *g >= 0; ++g) {
    double cot[FIBERS] = {0}, grad, grad_se;
    cot[*g] = 1.0;
    assert_ok(hetinv_estimator_gradient(est, m, set, cot, FIBERS, map, &grad, &grad_se, 1));
    double precision, ref = reference(s, &fibers[*g], 1, &precision);
    snprintf(quantity, sizeof quantity, "dfiber_dsigma_a_c%.2g,%.2g_r%.2g_NA%.3g", fibers[*g].centre[0],
             fibers[*g].centre[1], fibers[*g].radius, fibers[*g].na);
    failures += !val_compare(case_id, quantity, ref, precision, grad, grad_se, z_max, seed);
  }
  hetinv_param_map_destroy(&map);
  hetinv_estimator_destroy(&est);
  for (int i = 0; i < FIBERS; ++i) hetinv_sensor_destroy(&sensors[i]);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_emitter_destroy(&e);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  return failures;
}

/* Air outside: NA 1 accepts everything; the on-axis disk's edge (ρ = 0.5 at
 * θ_e ≈ 49°, η_out·sin θ_e ≈ 0.75) binds for NA 0.8 and 1, the aperture
 * for 0.22 and 0.5. */
static void fibers_under_air_match_the_closed_form(void **state) {
  (void)state;
  const slab_t s = {1.0, 0.5, 1.5, 1.0};
  const fiber_case_t fibers[FIBERS] = {{{0.0, 0.0}, 0.5, 0.22}, {{0.0, 0.0}, 0.5, 0.5}, {{0.0, 0.0}, 0.5, 0.8},
                                       {{0.0, 0.0}, 0.5, 1.0},  {{0.8, 0.3}, 0.4, 0.39}, {{0.8, 0.3}, 0.4, 1.0}};
  const int gradients[] = {-1};
  val_assert_all_passed(check_fibers("FB1", &s, fibers, gradients));
}

/* Water outside (η_out = 1.33): NA up to 1.33; the σa gradient of an
 * aperture-bound and of an off-axis fiber. */
static void fibers_under_water_match_the_closed_form(void **state) {
  (void)state;
  const slab_t s = {1.0, 0.5, 1.4, 1.33};
  const fiber_case_t fibers[FIBERS] = {{{0.0, 0.0}, 0.5, 0.22}, {{0.0, 0.0}, 0.5, 0.5},  {{0.0, 0.0}, 0.5, 1.0},
                                       {{0.0, 0.0}, 0.5, 1.33}, {{0.35, -0.2}, 0.3, 0.5}, {{0.35, -0.2}, 0.3, 1.33}};
  const int gradients[] = {1, 5, -1};
  val_assert_all_passed(check_fibers("FB2", &s, fibers, gradients));
}

/* In a scattering medium there is no closed form: the gradient pass against
 * central finite differences with common random numbers, as
 * test_gradient_fd.c does for the other kinds (its scene: 3 × 3 × 3 voxels of
 * 0.5 mm, σa 0.2–1, σs 1–5 /mm, g 0.1–0.6, η = 1.3 in air, a beam into the top
 * face's centre; its steps, 10 % of σ and 0.05 for g, and its threshold, the
 * Student-t Bonferroni bound with Welch's degrees of freedom). Two fibers:
 * one on the top face beside the beam (reflectance), one under it
 * (transmittance), NA 0.5 and 0.39. A set of exit sensors only takes the
 * SIMD photon loop with delta-tracked flights split into voxels when a path
 * scores; the finite differences render the same set. */
#define FD_COMPARISONS 24
#define FD_STREAMS 64
#define FD_PHOTONS 4.8e5 /* per side of each difference, all streams together */
#define FD_GRAD_PHOTONS 4e5
#define FD_GRAD_STREAM 1000 /* independent of the differences' streams 0..63 */

static void gradient_in_a_scattering_medium_matches_crn_finite_differences(void **state) {
  (void)state;
  enum { VALUES = 2, NVOX = 4 };
  static const int32_t voxel[NVOX][3] = {{1, 1, 1}, {1, 1, 2}, {2, 1, 2}, {1, 1, 0}};
  static const char *const value_name[VALUES] = {"top_fiber", "bottom_fiber"};
  hetinv_context_t *ctx = val_context(seed, 1);
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1.5, 1.5, 1.5}, (int32_t[]){3, 3, 3}, &m));
  assert_ok(hetinv_medium_set_ior(m, 1.3, 1.0));
  uint64_t table = 0x3a3a3; /* test_gradient_fd.c's medium */
  for (int32_t z = 0; z < 3; ++z) {
    for (int32_t y = 0; y < 3; ++y) {
      for (int32_t x = 0; x < 3; ++x) {
        double sa = 0.2 + 0.8 * grad_uniform(&table), ss = 1.0 + 4.0 * grad_uniform(&table);
        double g = 0.1 + 0.5 * grad_uniform(&table);
        assert_ok(hetinv_medium_set_voxel(m, x, y, z, sa, ss, g));
      }
    }
  }
  assert_ok(hetinv_medium_commit(m));
  hetinv_emitter_t *beam = NULL;
  assert_ok(hetinv_emitter_create_ideal(m, (double[]){0.75, 0.75, 2.5}, (double[]){0, 0, -1}, &beam));
  hetinv_sensor_t *top = NULL, *bottom = NULL;
  assert_ok(hetinv_sensor_create_fiber(m, HETINV_FACE_Z_MAX, (double[]){1.1, 0.75}, 0.3, 0.5, &top));
  assert_ok(hetinv_sensor_create_fiber(m, HETINV_FACE_Z_MIN, (double[]){0.75, 0.75}, 0.5, 0.39, &bottom));
  hetinv_pathlength_t *steady = NULL;
  assert_ok(hetinv_pathlength_create_steady(ctx, &steady));
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(ctx, &set));
  assert_ok(hetinv_measurements_add(set, beam, top, steady, NULL));
  assert_ok(hetinv_measurements_add(set, beam, bottom, steady, NULL));
  double t0 = grad_now();

  hetinv_estimator_t *fd_est = grad_fd_estimator(ctx, FD_PHOTONS, FD_STREAMS);
  double per_stream, fd_mean[NVOX][3][VALUES], fd_se[NVOX][3][VALUES], h_used[NVOX][3];
  assert_ok(hetinv_estimator_get_param(fd_est, HETINV_ESTIMATOR_PHOTONS, &per_stream));
  for (int v = 0; v < NVOX; ++v) {
    grad_fd_voxel(fd_est, m, set, voxel[v], VALUES, FD_STREAMS, fd_mean[v][0], fd_se[v][0], h_used[v]);
  }
  hetinv_estimator_destroy(&fd_est);
  double t1 = grad_now();

  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, HETINV_FREE_ALL, &map));
  hetinv_estimator_t *est = val_estimator(ctx, FD_GRAD_PHOTONS);
  assert_ok(hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, FD_GRAD_STREAM));
  double grad[VALUES][81], grad_se[VALUES][81], value[VALUES], value_se[VALUES];
  assert_ok(hetinv_estimator_render(est, m, set, value, value_se, NULL, VALUES));
  for (int n = 0; n < VALUES; ++n) {
    double cot[VALUES] = {0};
    cot[n] = 1.0;
    assert_ok(hetinv_estimator_gradient(est, m, set, cot, VALUES, map, grad[n], grad_se[n], 81));
    val_note("FB3", value_name[n], value[n], value_se[n]);
  }
  printf("finite differences: %d x 2 renders of %.0f photons x %d streams in %.1f s; gradients in %.1f s\n",
         NVOX * 3, per_stream, FD_STREAMS, t1 - t0, grad_now() - t1);
  int failures = 0;
  for (int v = 0; v < NVOX; ++v) {
    size_t k = (size_t)voxel[v][0] + 3 * ((size_t)voxel[v][1] + 3 * (size_t)voxel[v][2]);
    for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
      for (int n = 0; n < VALUES; ++n) {
        char name[96];
        snprintf(name, sizeof name, "FB3/%s/%s/(%d,%d,%d)/h=%.4g", value_name[n], hetinv_param_name(p),
                 (int)voxel[v][0], (int)voxel[v][1], (int)voxel[v][2], h_used[v][p]);
        failures += !grad_compare(name, fd_mean[v][p][n], fd_se[v][p][n], FD_STREAMS - 1.0,
                                  grad[n][(size_t)p * 27 + k], grad_se[n][(size_t)p * 27 + k], GRAD_BATCH_DOF,
                                  FD_COMPARISONS, seed);
      }
    }
  }
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  hetinv_measurements_destroy(&set);
  hetinv_pathlength_destroy(&steady);
  hetinv_sensor_destroy(&top);
  hetinv_sensor_destroy(&bottom);
  hetinv_emitter_destroy(&beam);
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  val_assert_all_passed(failures);
}

int main(void) {
  seed = val_seed(SEED);
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(fibers_under_air_match_the_closed_form),
      cmocka_unit_test(fibers_under_water_match_the_closed_form),
      cmocka_unit_test(gradient_in_a_scattering_medium_matches_crn_finite_differences),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
