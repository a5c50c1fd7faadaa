/* The smoothness prior (HETINV_OPTIMIZER_SMOOTHNESS), white-box: its
 * gradient against central differences of its value (exact up to rounding:
 * the prior is quadratic), its value on constant fields and on ramps (the
 * Dirichlet energy of the unit cube, the same at every resolution up to the
 * cell-centred sampling), blocks of different parameters kept apart, and
 * λ = 0 leaving the gradient untouched. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

#include "optimize/optimizer_internal.h"

typedef struct fixture {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_param_map_t *map;
  hetinv_optimizer_t opt; /* only param, k and scale are read */
  double *scale;
} fixture_t;

/* An identity map of σa and g (two blocks) on a dims grid, with scales 3
 * (σa) and 0.5 (g). */
static void fixture_init(fixture_t *f, const int32_t dims[3], double lambda) {
  *f = (fixture_t){0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  assert_ok(hetinv_medium_create(f->ctx, (double[]){0, 0, 0}, (double[]){1, 2, 3}, dims, &f->medium));
  uint32_t free_mask = HETINV_FREE(HETINV_PARAM_SIGMA_A) | HETINV_FREE(HETINV_PARAM_G);
  assert_ok(hetinv_param_map_create_identity(f->medium, free_mask, &f->map));
  size_t k = hetinv_param_map_size(f->map), cells = k / 2;
  f->scale = calloc(k, sizeof(double));
  assert_non_null(f->scale);
  for (size_t i = 0; i < k; ++i) f->scale[i] = i < cells ? 3.0 : 0.5;
  f->opt.param[HETINV_OPTIMIZER_SMOOTHNESS] = lambda;
  f->opt.k = k;
  f->opt.scale = f->scale;
}

static void fixture_release(fixture_t *f) {
  free(f->scale);
  hetinv_param_map_destroy(&f->map);
  hetinv_medium_destroy(&f->medium);
  hetinv_context_destroy(&f->ctx);
}

static double *zeros(size_t k) {
  double *v = calloc(k, sizeof(double));
  assert_non_null(v);
  return v;
}

static double prior(const fixture_t *f, const double *pi) {
  double *grad = zeros(f->opt.k);
  double r = hv_smoothness_add(&f->opt, f->map, pi, grad);
  free(grad);
  return r;
}

/* Random π: the gradient matches central differences, and is added to what
 * the gradient held. */
static void gradient_matches_differences(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, (int32_t[]){3, 2, 4}, 7.5);
  size_t k = f.opt.k;
  double *pi = zeros(k), *grad = zeros(k);
  srand(12345);
  for (size_t i = 0; i < k; ++i) {
    pi[i] = f.scale[i] * (double)rand() / RAND_MAX;
    grad[i] = 0.25 * (double)i;
  }
  double r = hv_smoothness_add(&f.opt, f.map, pi, grad);
  assert_true(r > 0.0);
  for (size_t i = 0; i < k; ++i) {
    double h = 1e-3 * f.scale[i], keep = pi[i];
    pi[i] = keep + h;
    double up = prior(&f, pi);
    pi[i] = keep - h;
    double down = prior(&f, pi);
    pi[i] = keep;
    double fd = (up - down) / (2.0 * h), analytic = grad[i] - 0.25 * (double)i;
    if (!(fabs(fd - analytic) <= 1e-7 * (fabs(fd) + r / f.scale[i]))) {
      print_error("entry %zu: gradient %.17g, central difference %.17g\n", i, analytic, fd);
      fail();
    }
  }
  free(pi);
  free(grad);
  fixture_release(&f);
}

/* A constant block costs nothing; a ramp u = (i + 1/2) / n along one axis
 * costs λ (n − 1) / n, which tends to λ, the energy of u = x on the unit
 * cube, at every grid shape; the other block's ramp adds its own. */
static void ramps_cost_their_dirichlet_energy(void **state) {
  (void)state;
  const int32_t shapes[3][3] = {{4, 1, 1}, {8, 3, 2}, {5, 4, 6}};
  for (int s = 0; s < 3; ++s) {
    for (int axis = 0; axis < 3; ++axis) {
      int32_t n = shapes[s][axis];
      if (n < 2) continue;
      fixture_t f;
      double lambda = 2.0;
      fixture_init(&f, shapes[s], lambda);
      size_t k = f.opt.k, cells = k / 2;
      double *pi = zeros(k);
      for (size_t i = 0; i < k; ++i) pi[i] = 0.4 * f.scale[i];
      assert_true(prior(&f, pi) == 0.0);
      size_t stride = axis == 0 ? 1 : axis == 1 ? (size_t)shapes[s][0] : (size_t)shapes[s][0] * (size_t)shapes[s][1];
      for (size_t c = 0; c < cells; ++c) {
        size_t along = c / stride % (size_t)n;
        pi[c] = f.scale[c] * ((double)along + 0.5) / (double)n;
      }
      double want = lambda * (double)(n - 1) / (double)n;
      assert_true(fabs(prior(&f, pi) - want) <= 1e-12 * want);
      for (size_t c = 0; c < cells; ++c) pi[cells + c] = f.scale[cells + c] * (1.0 - pi[c] / f.scale[c]);
      assert_true(fabs(prior(&f, pi) - 2.0 * want) <= 1e-12 * want);
      free(pi);
      fixture_release(&f);
    }
  }
}

/* λ = 0 (the default): nothing is added, not even zeros' rounding. */
static void zero_weight_adds_nothing(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, (int32_t[]){3, 1, 3}, 0.0);
  size_t k = f.opt.k;
  double *pi = zeros(k), *grad = zeros(k);
  for (size_t i = 0; i < k; ++i) {
    pi[i] = (double)(i % 5);
    grad[i] = -0.0;
  }
  assert_true(hv_smoothness_add(&f.opt, f.map, pi, grad) == 0.0);
  for (size_t i = 0; i < k; ++i) assert_true(grad[i] == 0.0 && signbit(grad[i]));
  free(pi);
  free(grad);
  fixture_release(&f);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(gradient_matches_differences),
      cmocka_unit_test(ramps_cost_their_dirichlet_energy),
      cmocka_unit_test(zero_weight_adds_nothing),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
