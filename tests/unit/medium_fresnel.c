/* The smooth dielectric boundary (lib/medium/fresnel.h), against the values of
 * tests/validation/transport-cases.md (scottprahl/iadpython
 * tests/test_fresnel.py). Deterministic: tolerances are half a unit in the
 * last digit the reference gives (one unit where it is truncated). */
#include <math.h>

#include "test_support.h"

#include "core/rng.h"
#include "medium/fresnel.h"

/* The seed of the randomized test running, printed with any failure. */
static uint64_t current_seed;

static void assert_near(double actual, double expected, double tol) {
  if (!(fabs(actual - expected) <= tol)) {
    print_error("%.17g, expected %.17g (tolerance %g)\n", actual, expected, tol);
    if (current_seed != 0) print_error("seed %#llx\n", (unsigned long long)current_seed);
    fail();
  }
}

static double reflectance(double cos_i, double eta) {
  double cos_t;
  return hv_fresnel_dielectric(cos_i, eta, &cos_t);
}

static double dot(const double a[3], const double b[3]) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void air_to_glass_matches_reference(void **state) {
  (void)state;
  assert_near(reflectance(1.0, 1.5), 0.04, 1e-15);
  assert_near(reflectance(0.5, 1.5), 0.0891867128, 5e-11);
  assert_near(reflectance(0.2, 1.5), 0.338894, 5e-7);
}

static void glass_to_air_matches_reference(void **state) {
  (void)state;
  assert_near(reflectance(0.8, 1.0 / 1.5), 0.11414110022, 5e-12);
}

static void refracted_cosine_matches_reference(void **state) {
  (void)state;
  double cos_t = -1.0;
  hv_fresnel_dielectric(0.5, 1.5, &cos_t);
  assert_near(cos_t, 0.81649658, 5e-9);
}

static void critical_angle_separates_total_reflection(void **state) {
  (void)state;
  double eta = 1.0 / 1.5, c = hv_fresnel_critical_cos(eta), cos_t;
  assert_near(c, 0.7453559, 1e-7); /* the reference is truncated: 0.74535599... */
  assert_true(hv_fresnel_dielectric(c - 1e-9, eta, &cos_t) == 1.0);
  assert_true(cos_t == 0.0);
  assert_true(hv_fresnel_dielectric(c + 1e-9, eta, &cos_t) < 1.0);
  assert_true(cos_t > 0.0);
  assert_true(hv_fresnel_critical_cos(1.5) == 0.0); /* no total reflection entering */
}

static void index_matched_boundary_reflects_nothing_and_does_not_bend(void **state) {
  (void)state;
  for (double c = 0.05; c <= 1.0; c += 0.05) {
    double cos_t;
    assert_true(hv_fresnel_dielectric(c, 1.0, &cos_t) == 0.0);
    assert_near(cos_t, c, 1e-15);
  }
  double w[3] = {0.6, 0.0, -0.8}, n[3] = {0.0, 0.0, 1.0}, wt[3];
  assert_true(hv_refract(w, n, 1.0, wt));
  for (int i = 0; i < 3; ++i) assert_near(wt[i], w[i], 1e-15);
}

static void reflectance_is_reciprocal(void **state) {
  (void)state;
  /* R(θi, η) = R(θt, 1/η): the same interface seen from the other side. */
  const double etas[] = {1.5, 1.3, 1.0 / 1.33, 2.4};
  for (size_t k = 0; k < sizeof etas / sizeof etas[0]; ++k) {
    /* From 1/8 up: nearer grazing both sides approach a square-root
     * singularity (the critical angle seen from behind) and lose digits. */
    for (double c = 0.125; c <= 1.0; c += 1.0 / 64) {
      double cos_t, r = hv_fresnel_dielectric(c, etas[k], &cos_t);
      if (r == 1.0) continue; /* total reflection has no transmitted side */
      double cos_back, r_back = hv_fresnel_dielectric(cos_t, 1.0 / etas[k], &cos_back);
      assert_near(r_back, r, 1e-14);
      assert_near(cos_back, c, 1e-12);
    }
  }
}

static void refracted_direction_is_unit_and_obeys_snell(void **state) {
  (void)state;
  current_seed = 0x452821e638d01377;
  hv_rng_t rng = hv_rng_init(current_seed, 0, 0, 0);
  const double m[3] = {0.0, 0.6, 0.8}; /* a unit normal off the axes */
  for (int k = 0; k < 2000; ++k) {
    double eta = k % 2 ? 1.5 : 1.0 / 1.3;
    double sign = k % 4 < 2 ? 1.0 : -1.0; /* either orientation of the normal */
    double normal[3] = {sign * m[0], sign * m[1], sign * m[2]};
    double z = 2.0 * hv_rng_uniform(&rng) - 1.0, phi = 6.283185307179586 * hv_rng_uniform(&rng);
    double s = sqrt(1.0 - z * z);
    double w[3] = {s * cos(phi), s * sin(phi), z}, wt[3];
    double cos_i = fabs(dot(w, normal)), cos_t;
    double r = hv_fresnel_dielectric(cos_i, eta, &cos_t);
    if (!hv_refract(w, normal, eta, wt)) {
      assert_near(r, 1.0, 0.0);
      continue;
    }
    assert_near(dot(wt, wt), 1.0, 1e-14);
    assert_true((dot(wt, normal) > 0) == (dot(w, normal) > 0)); /* crossed the plane */
    assert_near(fabs(dot(wt, normal)), cos_t, 1e-14);
    /* η_i sinθi = η_t sinθt, and wt stays in the plane of w and the normal. */
    assert_near(sqrt(1.0 - cos_i * cos_i), eta * sqrt(fmax(0.0, 1.0 - cos_t * cos_t)), 1e-12);
    double c[3] = {w[1] * m[2] - w[2] * m[1], w[2] * m[0] - w[0] * m[2], w[0] * m[1] - w[1] * m[0]};
    assert_near(dot(c, wt), 0.0, 1e-14);
  }
  current_seed = 0;
}

static void total_internal_reflection_refuses_to_refract(void **state) {
  (void)state;
  double w[3] = {0.8, 0.0, 0.6}, n[3] = {0.0, 0.0, 1.0}, wt[3] = {7.0, 7.0, 7.0};
  assert_false(hv_refract(w, n, 1.0 / 1.5, wt)); /* cosθ = 0.6 < 0.745 */
  assert_true(wt[0] == 7.0 && wt[1] == 7.0 && wt[2] == 7.0);
}

static void reflection_flips_the_normal_component(void **state) {
  (void)state;
  double w[3] = {0.6, 0.0, -0.8}, n[3] = {0.0, 0.0, -1.0}, out[3];
  hv_reflect(w, n, out);
  assert_near(out[0], 0.6, 0.0);
  assert_near(out[1], 0.0, 0.0);
  assert_near(out[2], 0.8, 1e-16);
}

static void radiance_scale_conserves_flux(void **state) {
  (void)state;
  /* Flux through area dA: L cosθ dω dA. Across a plane φ is kept and
   * dω = sinθ dθ dφ, so the transmitted flux L_t cosθt sinθt dθt must be the
   * fraction (1 - R) of L_i cosθi sinθi dθi, with L_t = L_i · scale. */
  const double etas[] = {1.5, 1.0 / 1.5, 1.3};
  const double h = 1e-6;
  for (size_t k = 0; k < 3; ++k) {
    for (double ti = 0.1; ti < 1.4; ti += 0.1) {
      double eta = etas[k], cos_t, cos_a, cos_b;
      double r = hv_fresnel_dielectric(cos(ti), eta, &cos_t);
      if (r == 1.0 || hv_fresnel_dielectric(cos(ti + h), eta, &cos_b) == 1.0) continue;
      hv_fresnel_dielectric(cos(ti - h), eta, &cos_a);
      double dtt = (acos(cos_b) - acos(cos_a)) / (2.0 * h); /* dθt/dθi */
      double tt = acos(cos_t);
      double in = cos(ti) * sin(ti), out = cos_t * sin(tt) * dtt;
      assert_near(hv_fresnel_radiance_scale(r, eta) * out, (1.0 - r) * in, 1e-8);
    }
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(air_to_glass_matches_reference),
      cmocka_unit_test(glass_to_air_matches_reference),
      cmocka_unit_test(refracted_cosine_matches_reference),
      cmocka_unit_test(critical_angle_separates_total_reflection),
      cmocka_unit_test(index_matched_boundary_reflects_nothing_and_does_not_bend),
      cmocka_unit_test(reflectance_is_reciprocal),
      cmocka_unit_test(refracted_direction_is_unit_and_obeys_snell),
      cmocka_unit_test(total_internal_reflection_refuses_to_refract),
      cmocka_unit_test(reflection_flips_the_normal_component),
      cmocka_unit_test(radiance_scale_conserves_flux),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
