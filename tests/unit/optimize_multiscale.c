/* The multi-scale step (HETINV_OPTIMIZER_MULTISCALE), white-box: each
 * entry's gradient gains α times its parameter's mean gradient over its
 * block at every coarser scale, checked against a brute-force sum over
 * each block's cells on grids whose sides are not powers of two; a
 * constant gradient scaled by 1 + α·levels; a pattern of zero block means
 * unchanged; frozen entries neither moved nor counted; the result a descent
 * direction; α = 0 leaving the gradient untouched. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

#include "optimize/optimizer_internal.h"

typedef struct fixture {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_param_map_t *map;
  hetinv_optimizer_t opt; /* only param, k, grad and multiscale are used */
  int32_t dims[3];
  size_t cells;
} fixture_t;

/* An identity map of σa and g (two blocks) on a dims grid. */
static void fixture_init(fixture_t *f, const int32_t dims[3], double alpha) {
  *f = (fixture_t){0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 1;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  assert_ok(hetinv_medium_create(f->ctx, (double[]){0, 0, 0}, (double[]){1, 2, 3}, dims, &f->medium));
  uint32_t free_mask = HETINV_FREE(HETINV_PARAM_SIGMA_A) | HETINV_FREE(HETINV_PARAM_G);
  assert_ok(hetinv_param_map_create_identity(f->medium, free_mask, &f->map));
  for (int a = 0; a < 3; ++a) f->dims[a] = dims[a];
  f->opt.k = hetinv_param_map_size(f->map);
  f->cells = f->opt.k / 2;
  f->opt.param[HETINV_OPTIMIZER_MULTISCALE] = alpha;
  f->opt.grad = calloc(f->opt.k, sizeof(double));
  f->opt.multiscale = calloc(2 * f->opt.k, sizeof(double));
  assert_non_null(f->opt.grad);
  assert_non_null(f->opt.multiscale);
}

static void fixture_release(fixture_t *f) {
  free(f->opt.grad);
  free(f->opt.multiscale);
  hetinv_param_map_destroy(&f->map);
  hetinv_medium_destroy(&f->medium);
  hetinv_context_destroy(&f->ctx);
}

static void coords(const fixture_t *f, size_t c, int32_t v[3]) {
  v[0] = (int32_t)(c % (size_t)f->dims[0]);
  v[1] = (int32_t)(c / (size_t)f->dims[0] % (size_t)f->dims[1]);
  v[2] = (int32_t)(c / ((size_t)f->dims[0] * (size_t)f->dims[1]));
}

/* Levels of the dims grid: blocks of 2, 4, ... cells until one block. */
static int levels_of(const int32_t dims[3]) {
  int levels = 0;
  for (int32_t b = 2;; b *= 2) {
    ++levels;
    if (b >= dims[0] && b >= dims[1] && b >= dims[2]) return levels;
  }
}

/* g_i + α Σ_levels (Σ over the cells of i's block of g) / (cells of the
 * block), frozen entries left out of the sums and left as they are. */
static void reference(const fixture_t *f, const double *g, const uint8_t *frozen, double alpha, double *out) {
  int levels = levels_of(f->dims);
  for (size_t i = 0; i < f->opt.k; ++i) {
    out[i] = g[i];
    if (frozen && frozen[i]) continue;
    size_t p = i / f->cells;
    int32_t vi[3];
    coords(f, i % f->cells, vi);
    for (int l = 0, b = 2; l < levels; ++l, b *= 2) {
      double sum = 0.0;
      size_t size = 0;
      for (size_t c = 0; c < f->cells; ++c) {
        int32_t vc[3];
        coords(f, c, vc);
        if (vc[0] / b != vi[0] / b || vc[1] / b != vi[1] / b || vc[2] / b != vi[2] / b) continue;
        ++size;
        size_t j = p * f->cells + c;
        if (!(frozen && frozen[j])) sum += g[j];
      }
      out[i] += alpha * sum / (double)size;
    }
  }
}

static void matches_block_sums(void **state) {
  (void)state;
  const int32_t shapes[3][3] = {{5, 3, 2}, {7, 1, 6}, {1, 9, 1}};
  srand(4321);
  for (int s = 0; s < 3; ++s) {
    for (int with_frozen = 0; with_frozen < 2; ++with_frozen) {
      fixture_t f;
      double alpha = 0.7;
      fixture_init(&f, shapes[s], alpha);
      size_t k = f.opt.k;
      double *g = calloc(k, sizeof(double)), *want = calloc(k, sizeof(double));
      uint8_t *frozen = calloc(k, 1);
      assert_non_null(g);
      assert_non_null(want);
      assert_non_null(frozen);
      for (size_t i = 0; i < k; ++i) {
        g[i] = f.opt.grad[i] = 2.0 * rand() / RAND_MAX - 1.0 + (i < f.cells ? 0.3 : -5.0);
        frozen[i] = with_frozen && i % 3 == 1;
      }
      reference(&f, g, with_frozen ? frozen : NULL, alpha, want);
      hv_multiscale_apply(&f.opt, f.map, with_frozen ? frozen : NULL);
      double gg = 0.0, gm = 0.0;
      for (size_t i = 0; i < k; ++i) {
        if (!(fabs(f.opt.grad[i] - want[i]) <= 1e-12 * (1.0 + fabs(want[i])))) {
          print_error("shape %d, entry %zu: %.17g, reference %.17g\n", s, i, f.opt.grad[i], want[i]);
          fail();
        }
        if (with_frozen && frozen[i]) assert_true(f.opt.grad[i] == g[i]);
        gg += g[i] * g[i];
        gm += g[i] * f.opt.grad[i];
      }
      /* A positive definite preconditioner: still a descent direction. */
      if (!with_frozen) assert_true(gm >= gg);
      free(g);
      free(want);
      free(frozen);
      fixture_release(&f);
    }
  }
}

/* A constant gradient c becomes c (1 + α·levels); one whose every block
 * mean is zero (+1, −1 along x on a grid of 8) is left as it was. */
static void constant_and_balanced_gradients(void **state) {
  (void)state;
  fixture_t f;
  const int32_t dims[3] = {8, 3, 1};
  fixture_init(&f, dims, 0.5);
  for (size_t i = 0; i < f.opt.k; ++i) f.opt.grad[i] = i < f.cells ? 2.0 : -1.0;
  hv_multiscale_apply(&f.opt, f.map, NULL);
  int levels = levels_of(dims); /* 2, 4, 8 */
  assert_int_equal(levels, 3);
  for (size_t i = 0; i < f.opt.k; ++i) {
    double want = (i < f.cells ? 2.0 : -1.0) * (1.0 + 0.5 * levels);
    assert_true(fabs(f.opt.grad[i] - want) <= 1e-14);
  }
  for (size_t i = 0; i < f.opt.k; ++i) f.opt.grad[i] = (i % f.cells) % 2 ? -1.0 : 1.0;
  hv_multiscale_apply(&f.opt, f.map, NULL);
  for (size_t i = 0; i < f.opt.k; ++i) assert_true(f.opt.grad[i] == ((i % f.cells) % 2 ? -1.0 : 1.0));
  fixture_release(&f);
}

/* α = 0 (the default), or a single cell: nothing is added, not even zeros'
 * rounding. */
static void zero_weight_adds_nothing(void **state) {
  (void)state;
  const int32_t shapes[2][3] = {{3, 1, 3}, {1, 1, 1}};
  const double alphas[2] = {0.0, 1.0};
  for (int s = 0; s < 2; ++s) {
    fixture_t f;
    fixture_init(&f, shapes[s], alphas[s]);
    for (size_t i = 0; i < f.opt.k; ++i) f.opt.grad[i] = -0.0;
    hv_multiscale_apply(&f.opt, f.map, NULL);
    for (size_t i = 0; i < f.opt.k; ++i) assert_true(f.opt.grad[i] == 0.0 && signbit(f.opt.grad[i]));
    fixture_release(&f);
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(matches_block_sums),
      cmocka_unit_test(constant_and_balanced_gradients),
      cmocka_unit_test(zero_weight_adds_nothing),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
