/* Parameter maps: sizes and layout of π, apply (trilinear, cell-centred,
 * clamped), extract (averages), pull-back (the exact adjoint of apply) and
 * every error path with its exact code. */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

#define SA HETINV_FREE(HETINV_PARAM_SIGMA_A)
#define SS HETINV_FREE(HETINV_PARAM_SIGMA_S)
#define GG HETINV_FREE(HETINV_PARAM_G)

/* |a - b| <= tol, printing both on failure. */
#define assert_close(a, b, tol) \
  do { \
    double a_ = (a), b_ = (b); \
    if (!(fabs(a_ - b_) <= (tol))) { \
      print_error("%s = %.17g, expected %s = %.17g (tolerance %g)\n", #a, a_, #b, b_, (double)(tol)); \
      fail(); \
    } \
  } while (0)

static hetinv_medium_t *make(hetinv_context_t *ctx, int32_t nx, int32_t ny, int32_t nz) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 2, 3},
                                 (int32_t[]){nx, ny, nz}, &m));
  return m;
}

/* Deterministic uniform in [0, 1) (SplitMix64). */
static double uniform(uint64_t *s) {
  uint64_t z = (*s += 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return (double)(z >> 11) * 0x1.0p-53;
}

/* Fills every voxel with distinct valid values (σa, σs in [0.5, 1.5), g in [-0.5, 0.5)). */
static void fill_distinct(hetinv_medium_t *m, uint64_t seed) {
  int32_t d[3];
  assert_ok(hetinv_medium_get_dims(m, d));
  for (int32_t z = 0; z < d[2]; ++z) {
    for (int32_t y = 0; y < d[1]; ++y) {
      for (int32_t x = 0; x < d[0]; ++x) {
        assert_ok(hetinv_medium_set_voxel(m, x, y, z, 0.5 + uniform(&seed), 0.5 + uniform(&seed),
                                          uniform(&seed) - 0.5));
      }
    }
  }
}

/* ------------------------------------------------------------------------ */
/* Sizes, dims, entries. */

static void identity_size_dims_and_entries(void **state) {
  hetinv_medium_t *m = make(*state, 4, 3, 2); /* 24 voxels */
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, SA | GG, &map));
  assert_non_null(map);
  assert_int_equal(hetinv_param_map_size(map), 48);
  assert_int_equal(hetinv_param_map_free_mask(map), SA | GG);
  int32_t d[3] = {0, 0, 0};
  assert_ok(hetinv_param_map_get_dims(map, d));
  assert_true(d[0] == 4 && d[1] == 3 && d[2] == 2);
  /* Parameter-major: the σa block, then the g block; cells in linear order. */
  hetinv_param_t p = -1;
  size_t cell = 999;
  assert_ok(hetinv_param_map_entry(map, 0, &p, &cell));
  assert_true(p == HETINV_PARAM_SIGMA_A && cell == 0);
  assert_ok(hetinv_param_map_entry(map, 23, &p, &cell));
  assert_true(p == HETINV_PARAM_SIGMA_A && cell == 23);
  assert_ok(hetinv_param_map_entry(map, 24, &p, &cell));
  assert_true(p == HETINV_PARAM_G && cell == 0);
  assert_ok(hetinv_param_map_entry(map, 47, &p, &cell));
  assert_true(p == HETINV_PARAM_G && cell == 23);
  assert_ok(hetinv_param_map_entry(map, 30, NULL, NULL));
  assert_ok(hetinv_param_map_entry(map, 30, NULL, &cell));
  assert_int_equal(cell, 6);
  assert_ok(hetinv_param_map_entry(map, 30, &p, NULL));
  assert_int_equal(p, HETINV_PARAM_G);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_param_map_entry(map, 48, &p, &cell));
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_param_map_entry(map, (size_t)-1, &p, &cell));
  hetinv_param_map_destroy(&map);
  assert_null(map);
  hetinv_medium_destroy(&m);
}

static void every_mask_orders_blocks_sa_ss_g(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 2);
  for (uint32_t mask = 1; mask <= HETINV_FREE_ALL; ++mask) {
    hetinv_param_map_t *map = NULL;
    assert_ok(hetinv_param_map_create_identity(m, mask, &map));
    int free_count = (mask & 1) + ((mask >> 1) & 1) + ((mask >> 2) & 1);
    assert_int_equal(hetinv_param_map_size(map), 8 * (size_t)free_count);
    assert_int_equal(hetinv_param_map_free_mask(map), mask);
    hetinv_param_t expect = -1, p;
    size_t cell;
    for (size_t i = 0; i < hetinv_param_map_size(map); ++i) {
      if (i % 8 == 0) { /* the next free parameter, in the order σa, σs, g */
        do ++expect; while (!(mask & HETINV_FREE(expect)));
      }
      assert_ok(hetinv_param_map_entry(map, i, &p, &cell));
      assert_int_equal(p, expect);
      assert_int_equal(cell, i % 8);
    }
    hetinv_param_map_destroy(&map);
  }
  hetinv_medium_destroy(&m);
}

static void coarse_size_and_dims(void **state) {
  hetinv_medium_t *m = make(*state, 4, 5, 3);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){2, 5, 1}, HETINV_FREE_ALL, &map));
  assert_int_equal(hetinv_param_map_size(map), 30);
  assert_int_equal(hetinv_param_map_free_mask(map), HETINV_FREE_ALL);
  int32_t d[3];
  assert_ok(hetinv_param_map_get_dims(map, d));
  assert_true(d[0] == 2 && d[1] == 5 && d[2] == 1);
  hetinv_param_t p;
  size_t cell;
  assert_ok(hetinv_param_map_entry(map, 10, &p, &cell));
  assert_true(p == HETINV_PARAM_SIGMA_S && cell == 0);
  assert_ok(hetinv_param_map_entry(map, 29, &p, &cell));
  assert_true(p == HETINV_PARAM_G && cell == 9);
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_param_map_entry(map, 30, &p, &cell));
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&m);
}

static void broadcast_size_and_dims(void **state) {
  hetinv_medium_t *m = make(*state, 4, 5, 3);
  const int32_t expect[3][3] = {{1, 5, 3}, {4, 1, 3}, {4, 5, 1}};
  for (int32_t axis = 0; axis < 3; ++axis) {
    hetinv_param_map_t *map = NULL;
    assert_ok(hetinv_param_map_create_broadcast(m, axis, SS, &map));
    int32_t d[3];
    assert_ok(hetinv_param_map_get_dims(map, d));
    assert_true(d[0] == expect[axis][0] && d[1] == expect[axis][1] && d[2] == expect[axis][2]);
    assert_int_equal(hetinv_param_map_size(map), (size_t)(d[0] * d[1] * d[2]));
    assert_int_equal(hetinv_param_map_free_mask(map), SS);
    hetinv_param_map_destroy(&map);
  }
  hetinv_medium_destroy(&m);
}

static void null_map_queries(void **state) {
  (void)state;
  assert_int_equal(hetinv_param_map_size(NULL), 0);
  assert_int_equal(hetinv_param_map_free_mask(NULL), 0);
  int32_t d[3];
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_get_dims(NULL, d));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_entry(NULL, 0, NULL, NULL));
  hetinv_param_map_destroy(NULL);
  hetinv_param_map_t *none = NULL;
  hetinv_param_map_destroy(&none);
  assert_null(none);
}

/* ------------------------------------------------------------------------ */
/* Creation errors, each with its exact code; *out is NULL after a failure. */

static void creation_errors(void **state) {
  hetinv_medium_t *m = make(*state, 4, 3, 2);
  static char dummy;
  hetinv_param_map_t *const sentinel = (hetinv_param_map_t *)(void *)&dummy;
  hetinv_param_map_t *map = sentinel;

  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_create_identity(m, SA, NULL));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_create_identity(NULL, SA, &map));
  assert_null(map);
  map = sentinel;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_create_identity(m, 0, &map));
  assert_null(map);
  assert_message_contains("free_mask");
  map = sentinel;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_create_identity(m, SA | (1u << 3), &map));
  assert_null(map);
  map = sentinel;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_create_identity(m, 0x80000000u, &map));
  assert_null(map);

  map = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_create_coarse(m, NULL, SA, &map));
  assert_null(map);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_create_coarse(m, (int32_t[]){1, 1, 1}, SA, NULL));
  map = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_create_coarse(NULL, (int32_t[]){1, 1, 1}, SA, &map));
  assert_null(map);
  const int32_t bad_coarse[][3] = {{0, 1, 1}, {1, 0, 1}, {1, 1, 0}, {5, 1, 1}, {1, 4, 1}, {1, 1, 3}, {-1, 1, 1}};
  for (size_t i = 0; i < sizeof bad_coarse / sizeof bad_coarse[0]; ++i) {
    map = sentinel;
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_create_coarse(m, bad_coarse[i], SA, &map));
    assert_null(map);
    assert_message_contains("coarse_dims");
  }
  map = sentinel;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_create_coarse(m, (int32_t[]){2, 2, 2}, 0, &map));
  assert_null(map);
  /* The full grid and a single cell are both allowed. */
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){4, 3, 2}, SA, &map));
  hetinv_param_map_destroy(&map);
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){1, 1, 1}, SA, &map));
  assert_int_equal(hetinv_param_map_size(map), 1);
  hetinv_param_map_destroy(&map);

  map = sentinel;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_param_map_create_broadcast(m, 3, SA, &map));
  assert_null(map);
  map = sentinel;
  assert_result(HETINV_ERROR_OUT_OF_RANGE, hetinv_param_map_create_broadcast(m, -1, SA, &map));
  assert_null(map);
  map = sentinel;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_create_broadcast(m, 1, 8u, &map));
  assert_null(map);
  map = sentinel;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_create_broadcast(NULL, 1, SA, &map));
  assert_null(map);
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_create_broadcast(m, 1, SA, NULL));
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* apply */

static void identity_apply_writes_exactly_pi(void **state) {
  hetinv_medium_t *m = make(*state, 3, 2, 2);
  fill_distinct(m, 11);
  hetinv_medium_t *before = NULL;
  assert_ok(hetinv_medium_clone(m, &before));
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, SS | GG, &map));
  double pi[24];
  for (int i = 0; i < 12; ++i) pi[i] = 0.1 + 0.37 * i;         /* σs */
  for (int i = 0; i < 12; ++i) pi[12 + i] = -0.9 + 0.15 * i;   /* g */
  assert_ok(hetinv_param_map_apply(map, pi, 24, m));
  const double *sa = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A);
  const double *ss = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S);
  const double *g = hetinv_medium_grid(m, HETINV_PARAM_G);
  const double *sa0 = hetinv_medium_grid(before, HETINV_PARAM_SIGMA_A);
  for (int k = 0; k < 12; ++k) {
    assert_true(ss[k] == pi[k]);
    assert_true(g[k] == pi[12 + k]);
    assert_true(sa[k] == sa0[k]); /* not free: untouched */
  }
  assert_false(hetinv_medium_is_committed(m));
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&before);
  hetinv_medium_destroy(&m);
}

/* 1-D weights of the 4 → 2 cell-centred map. In fine-voxel units the voxel
 * centres are 0.5, 1.5, 2.5, 3.5 and the coarse cell centres 1 and 3:
 * voxels 0 and 3 lie outside the outermost centres and are clamped to
 * them; voxel 1 is 3/4 cell 0 + 1/4 cell 1, voxel 2 its mirror.
 * w4to2[v][c] = weight of cell c in voxel v. */
static const double w4to2[4][2] = {{1.0, 0.0}, {0.75, 0.25}, {0.25, 0.75}, {0.0, 1.0}};

static void coarse_apply_is_trilinear_cell_centred_and_clamped(void **state) {
  hetinv_medium_t *m = make(*state, 4, 4, 4);
  fill_distinct(m, 12);
  hetinv_medium_t *before = NULL;
  assert_ok(hetinv_medium_clone(m, &before));
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){2, 2, 2}, SA | SS, &map));
  assert_int_equal(hetinv_param_map_size(map), 16);
  /* σa: an affine field of the cell indices, 1 + i + 2j + 4k, whose
   * interpolation is 1 + X(vx) + 2X(vy) + 4X(vz) with X = 0, 1/4, 3/4, 1.
   * σs: a single cell (1, 0, 1) set to 8: wx1·wy0·wz1 · 8 (the tensor
   * product, not only its affine part). */
  double pi[16] = {0};
  for (int c = 0; c < 8; ++c) pi[c] = 1.0 + (c & 1) + 2.0 * ((c >> 1) & 1) + 4.0 * ((c >> 2) & 1);
  pi[8 + 1 + 2 * (0 + 2 * 1)] = 8.0;
  assert_ok(hetinv_param_map_apply(map, pi, 16, m));
  static const double X[4] = {0.0, 0.25, 0.75, 1.0};
  for (int z = 0; z < 4; ++z) {
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 4; ++x) {
        double sa, ss, g, sa0, ss0, g0;
        assert_ok(hetinv_medium_get_voxel(m, x, y, z, &sa, &ss, &g));
        assert_ok(hetinv_medium_get_voxel(before, x, y, z, &sa0, &ss0, &g0));
        assert_close(sa, 1.0 + X[x] + 2.0 * X[y] + 4.0 * X[z], 1e-14);
        assert_close(ss, 8.0 * w4to2[x][1] * w4to2[y][0] * w4to2[z][1], 1e-14);
        assert_true(g == g0); /* not free: untouched, bit for bit */
      }
    }
  }
  /* A few values written out by hand. */
  double v;
  assert_ok(hetinv_medium_get_voxel(m, 0, 0, 0, &v, NULL, NULL));
  assert_close(v, 1.0, 1e-15); /* clamped to cell (0,0,0) */
  assert_ok(hetinv_medium_get_voxel(m, 3, 3, 3, &v, NULL, NULL));
  assert_close(v, 8.0, 1e-15); /* clamped to cell (1,1,1) = 1+1+2+4 */
  assert_ok(hetinv_medium_get_voxel(m, 1, 2, 0, &v, NULL, NULL));
  assert_close(v, 1.0 + 0.25 + 1.5, 1e-15);
  assert_ok(hetinv_medium_get_voxel(m, 2, 1, 3, NULL, &v, NULL));
  assert_close(v, 8.0 * 0.75 * 0.75 * 1.0, 1e-15); /* 4.5 */
  assert_ok(hetinv_medium_get_voxel(m, 1, 1, 2, NULL, &v, NULL));
  assert_close(v, 8.0 * 0.25 * 0.75 * 0.75, 1e-15); /* 1.125 */
  assert_ok(hetinv_medium_get_voxel(m, 3, 0, 0, NULL, &v, NULL));
  assert_close(v, 0.0, 1e-15); /* wz1(0) = 0 */
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&before);
  hetinv_medium_destroy(&m);
}

/* 5 → 3 along x (centres of the coarse cells at fine coordinates 5/6, 5/2,
 * 25/6 in voxel units): voxel v reads coarse coordinate 0.6 v - 0.2, i.e.
 * -0.2 → 0 (clamped), 0.4, 1.0, 1.6, 2.2 → 2 (clamped). 3 → 2 along y:
 * 2/3 (v + 1/2) - 1/2 = -1/6 → 0, 1/2, 7/6 → 1. One cell along z. */
static void coarse_apply_uneven_ratios(void **state) {
  hetinv_medium_t *m = make(*state, 5, 3, 2);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){3, 2, 1}, GG, &map));
  double pi[6] = {0.1, 0.4, -0.5, 0.3, 0.2, 0.6}; /* (cx, cy): x fastest */
  assert_ok(hetinv_param_map_apply(map, pi, 6, m));
  static const double wx[5][3] = {{1, 0, 0}, {0.6, 0.4, 0}, {0, 1, 0}, {0, 0.4, 0.6}, {0, 0, 1}};
  static const double wy[3][2] = {{1, 0}, {0.5, 0.5}, {0, 1}};
  for (int z = 0; z < 2; ++z) {
    for (int y = 0; y < 3; ++y) {
      for (int x = 0; x < 5; ++x) {
        double expect = 0.0;
        for (int cy = 0; cy < 2; ++cy) {
          for (int cx = 0; cx < 3; ++cx) expect += wx[x][cx] * wy[y][cy] * pi[cx + 3 * cy];
        }
        double g;
        assert_ok(hetinv_medium_get_voxel(m, x, y, z, NULL, NULL, &g));
        assert_close(g, expect, 1e-14);
      }
    }
  }
  double g;
  assert_ok(hetinv_medium_get_voxel(m, 1, 1, 1, NULL, NULL, &g));
  /* 0.5·(0.6·0.1 + 0.4·0.4) + 0.5·(0.6·0.3 + 0.4·0.2) = 0.11 + 0.13 */
  assert_close(g, 0.24, 1e-15);
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&m);
}

static void broadcast_apply_copies_along_the_axis(void **state) {
  hetinv_medium_t *m = make(*state, 3, 4, 2);
  fill_distinct(m, 13);
  hetinv_medium_t *before = NULL;
  assert_ok(hetinv_medium_clone(m, &before));
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_broadcast(m, 1, SA, &map)); /* cells (x, z): 3 × 1 × 2 */
  assert_int_equal(hetinv_param_map_size(map), 6);
  const double pi[6] = {0.5, 1.5, 2.5, 3.5, 4.5, 5.5};
  assert_ok(hetinv_param_map_apply(map, pi, 6, m));
  for (int z = 0; z < 2; ++z) {
    for (int y = 0; y < 4; ++y) {
      for (int x = 0; x < 3; ++x) {
        double sa, ss, g, sa0, ss0, g0;
        assert_ok(hetinv_medium_get_voxel(m, x, y, z, &sa, &ss, &g));
        assert_ok(hetinv_medium_get_voxel(before, x, y, z, &sa0, &ss0, &g0));
        assert_true(sa == pi[x + 3 * z]);
        assert_true(ss == ss0 && g == g0);
      }
    }
  }
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&before);
  hetinv_medium_destroy(&m);
}

static void apply_errors(void **state) {
  hetinv_medium_t *m = make(*state, 3, 2, 2);
  fill_distinct(m, 14);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, SA | SS, &map));
  double pi[24];
  for (int i = 0; i < 24; ++i) pi[i] = 0.25 + 0.125 * i;

  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_apply(NULL, pi, 24, m));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_apply(map, NULL, 24, m));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_apply(map, pi, 24, NULL));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, pi, 23, m));
  assert_message_contains("count is 23");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, pi, 25, m));
  /* Another grid, same voxel count: rejected all the same. */
  hetinv_medium_t *other = make(*state, 2, 3, 2);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, pi, 24, other));
  assert_message_contains("grid");
  hetinv_medium_destroy(&other);

  /* An invalid mapped value names its voxel, and nothing changes. */
  hetinv_medium_t *before = NULL;
  assert_ok(hetinv_medium_clone(m, &before));
  size_t bad = 2 + 3 * (1 + 2 * 1); /* voxel (2, 1, 1) */
  pi[12 + bad] = -0.5;              /* σs */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, pi, 24, m));
  assert_message_contains("sigma_s of voxel (2, 1, 1)");
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    assert_memory_equal(hetinv_medium_grid(m, p), hetinv_medium_grid(before, p), 12 * sizeof(double));
  }
  pi[12 + bad] = (double)NAN;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, pi, 24, m));
  assert_message_contains("voxel (2, 1, 1)");
  pi[12 + bad] = 1.0;
  pi[0] = (double)INFINITY; /* σa of voxel (0, 0, 0) */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, pi, 24, m));
  assert_message_contains("voxel (0, 0, 0)");
  pi[0] = 0.25;
  hetinv_param_map_destroy(&map);

  /* g outside (-1, 1), through a coarse map: the first offending voxel is named. */
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){1, 1, 1}, GG, &map));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, (double[]){1.0}, 1, m));
  assert_message_contains("g of voxel (0, 0, 0)");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_apply(map, (double[]){-1.5}, 1, m));
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    assert_memory_equal(hetinv_medium_grid(m, p), hetinv_medium_grid(before, p), 12 * sizeof(double));
  }
  assert_ok(hetinv_param_map_apply(map, (double[]){0.5}, 1, m));

  /* A committed medium is never modified. */
  assert_ok(hetinv_medium_commit(before));
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_param_map_apply(map, (double[]){0.5}, 1, before));
  assert_message_contains("committed");
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&before);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* extract */

static void extract_copies_and_averages(void **state) {
  hetinv_medium_t *m = make(*state, 4, 3, 2);
  fill_distinct(m, 15);
  const double *sa = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_A);
  const double *ss = hetinv_medium_grid(m, HETINV_PARAM_SIGMA_S);
  const double *g = hetinv_medium_grid(m, HETINV_PARAM_G);

  /* identity: a copy of each free block. */
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, SA | GG, &map));
  double pi[72];
  assert_ok(hetinv_param_map_extract(map, m, pi, 48));
  assert_memory_equal(pi, sa, 24 * sizeof(double));
  assert_memory_equal(pi + 24, g, 24 * sizeof(double));
  hetinv_param_map_destroy(&map);

  /* broadcast along z: the mean of the two voxels of each (x, y). */
  assert_ok(hetinv_param_map_create_broadcast(m, 2, SS, &map));
  assert_ok(hetinv_param_map_extract(map, m, pi, 12));
  for (int c = 0; c < 12; ++c) assert_close(pi[c], 0.5 * (ss[c] + ss[c + 12]), 1e-15);
  hetinv_param_map_destroy(&map);

  /* broadcast along x: the mean of the four voxels of each (y, z). */
  assert_ok(hetinv_param_map_create_broadcast(m, 0, SA, &map));
  assert_ok(hetinv_param_map_extract(map, m, pi, 6));
  for (int c = 0; c < 6; ++c) {
    double mean = 0.25 * (sa[4 * c] + sa[4 * c + 1] + sa[4 * c + 2] + sa[4 * c + 3]);
    assert_close(pi[c], mean, 1e-15);
  }
  hetinv_param_map_destroy(&map);

  /* coarse with one cell: the mean of every voxel. */
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){1, 1, 1}, HETINV_FREE_ALL, &map));
  assert_ok(hetinv_param_map_extract(map, m, pi, 3));
  const double *grids[3] = {sa, ss, g};
  for (int p = 0; p < 3; ++p) {
    double mean = 0.0;
    for (int k = 0; k < 24; ++k) mean += grids[p][k];
    assert_close(pi[p], mean / 24.0, 1e-14);
  }
  hetinv_param_map_destroy(&map);

  /* coarse 4 → 2 along x: an average (between the smallest and largest
   * voxel each cell reads), and exact on a constant medium. */
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){2, 3, 2}, SA, &map));
  assert_ok(hetinv_param_map_extract(map, m, pi, 12));
  for (int c = 0; c < 12; ++c) {
    int cx = c % 2, row = c / 2; /* row = (y, z) */
    double lo = (double)INFINITY, hi = -(double)INFINITY;
    for (int x = 0; x < 4; ++x) {
      if (w4to2[x][cx] == 0.0) continue;
      lo = fmin(lo, sa[4 * row + x]);
      hi = fmax(hi, sa[4 * row + x]);
    }
    assert_true(pi[c] >= lo - 1e-15 && pi[c] <= hi + 1e-15);
  }
  hetinv_medium_t *flat = make(*state, 4, 3, 2);
  assert_ok(hetinv_medium_fill(flat, 0.7, 2.0, 0.3));
  assert_ok(hetinv_param_map_extract(map, flat, pi, 12));
  for (int c = 0; c < 12; ++c) assert_close(pi[c], 0.7, 1e-15);
  hetinv_param_map_destroy(&map);

  /* extract ∘ apply is the identity for identity and broadcast maps. */
  assert_ok(hetinv_param_map_create_broadcast(m, 1, HETINV_FREE_ALL, &map));
  double in[24], out[24];
  for (int i = 0; i < 24; ++i) in[i] = 0.05 + 0.03 * i;
  assert_ok(hetinv_param_map_apply(map, in, 24, flat));
  assert_ok(hetinv_param_map_extract(map, flat, out, 24));
  for (int i = 0; i < 24; ++i) assert_close(out[i], in[i], 1e-15);
  hetinv_param_map_destroy(&map);

  /* A committed medium can be read. */
  assert_ok(hetinv_medium_commit(flat));
  assert_ok(hetinv_param_map_create_identity(flat, SS, &map));
  assert_ok(hetinv_param_map_extract(map, flat, pi, 24));
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&flat);
  hetinv_medium_destroy(&m);
}

static void extract_errors(void **state) {
  hetinv_medium_t *m = make(*state, 4, 3, 2);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, SA, &map));
  double pi[24];
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_extract(NULL, m, pi, 24));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_extract(map, NULL, pi, 24));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_extract(map, m, NULL, 24));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_extract(map, m, pi, 23));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_extract(map, m, pi, 0));
  hetinv_medium_t *other = make(*state, 4, 2, 3);
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_extract(map, other, pi, 24));
  hetinv_medium_destroy(&other);
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&m);
}

/* ------------------------------------------------------------------------ */
/* pullback: the adjoint of apply's linear part, ⟨A π, v⟩ = ⟨π, Aᵀ v⟩, with
 * A π the free blocks of the voxel fields apply() writes (the blocks of
 * the other parameters are not part of A: their entries of v must not
 * matter). */

static double adjoint_gap(hetinv_context_t *ctx, const int32_t fine[3], hetinv_param_map_t *map,
                          uint64_t *rng) {
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, fine, &m));
  size_t voxels = hetinv_medium_voxel_count(m), k = hetinv_param_map_size(map);
  double *pi = calloc(k, sizeof *pi), *pb = calloc(k, sizeof *pb);
  double *v = calloc(3 * voxels, sizeof *v);
  assert_true(pi && pb && v);
  for (size_t i = 0; i < k; ++i) {
    hetinv_param_t p;
    assert_ok(hetinv_param_map_entry(map, i, &p, NULL));
    /* valid values (interpolation is convex, so voxels stay valid) */
    pi[i] = p == HETINV_PARAM_G ? 1.8 * uniform(rng) - 0.9 : 3.0 * uniform(rng);
  }
  for (size_t i = 0; i < 3 * voxels; ++i) v[i] = 2.0 * uniform(rng) - 1.0;
  assert_ok(hetinv_param_map_apply(map, pi, k, m));
  assert_ok(hetinv_param_map_pullback(map, v, pb, k));
  double lhs = 0.0, rhs = 0.0, scale = 0.0;
  uint32_t mask = hetinv_param_map_free_mask(map);
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    if (!(mask & HETINV_FREE(p))) continue;
    const double *grid = hetinv_medium_grid(m, p);
    for (size_t j = 0; j < voxels; ++j) {
      lhs += grid[j] * v[(size_t)p * voxels + j];
      scale += fabs(grid[j] * v[(size_t)p * voxels + j]);
    }
  }
  for (size_t i = 0; i < k; ++i) rhs += pi[i] * pb[i];
  /* Changing v's non-free blocks changes nothing. */
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    if (mask & HETINV_FREE(p)) continue;
    for (size_t j = 0; j < voxels; ++j) v[(size_t)p * voxels + j] = 1e6;
  }
  double *pb2 = calloc(k, sizeof *pb2);
  assert_non_null(pb2);
  assert_ok(hetinv_param_map_pullback(map, v, pb2, k));
  assert_memory_equal(pb, pb2, k * sizeof(double));
  free(pb2);
  free(pi);
  free(pb);
  free(v);
  hetinv_medium_destroy(&m);
  return fabs(lhs - rhs) / (scale > 0.0 ? scale : 1.0);
}

static void pullback_is_the_adjoint_of_apply(void **state) {
  hetinv_context_t *ctx = *state;
  uint64_t rng = 2024;
  const int32_t fine[3] = {5, 4, 3};
  const int32_t coarse[][3] = {{5, 4, 3}, {2, 2, 2}, {3, 1, 2}, {1, 3, 1}, {4, 4, 3}, {1, 1, 1}};
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, fine, &m));
  int checked = 0;
  for (uint32_t mask = 1; mask <= HETINV_FREE_ALL; ++mask) {
    for (int trial = 0; trial < 3; ++trial) {
      hetinv_param_map_t *map = NULL;
      assert_ok(hetinv_param_map_create_identity(m, mask, &map));
      assert_true(adjoint_gap(ctx, fine, map, &rng) <= 1e-12);
      hetinv_param_map_destroy(&map);
      for (size_t c = 0; c < sizeof coarse / sizeof coarse[0]; ++c) {
        assert_ok(hetinv_param_map_create_coarse(m, coarse[c], mask, &map));
        double gap = adjoint_gap(ctx, fine, map, &rng);
        if (gap > 1e-12) {
          print_error("coarse %d x %d x %d, mask %u: relative gap %g\n", coarse[c][0], coarse[c][1],
                      coarse[c][2], mask, gap);
          fail();
        }
        hetinv_param_map_destroy(&map);
      }
      for (int32_t axis = 0; axis < 3; ++axis) {
        assert_ok(hetinv_param_map_create_broadcast(m, axis, mask, &map));
        assert_true(adjoint_gap(ctx, fine, map, &rng) <= 1e-12);
        hetinv_param_map_destroy(&map);
      }
      checked += 1 + (int)(sizeof coarse / sizeof coarse[0]) + 3;
    }
  }
  assert_int_equal(checked, 7 * 3 * 10);
  hetinv_medium_destroy(&m);
}

/* The pull-back of a one-hot voxel gradient is the column of weights that
 * voxel reads: for identity the same entry, for broadcast its cell, for
 * coarse 4 → 2 the hand-computed trilinear weights. */
static void pullback_of_one_voxel(void **state) {
  hetinv_medium_t *m = make(*state, 4, 4, 4);
  double v[192] = {0};
  size_t voxel = 1 + 4 * (2 + 4 * 3); /* (1, 2, 3) */
  v[64 + voxel] = 1.0;                /* ∂/∂σs of that voxel */
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_coarse(m, (int32_t[]){2, 2, 2}, SA | SS, &map));
  double pb[16];
  assert_ok(hetinv_param_map_pullback(map, v, pb, 16));
  for (int c = 0; c < 8; ++c) {
    assert_true(pb[c] == 0.0); /* the σa block */
    int cx = c & 1, cy = (c >> 1) & 1, cz = (c >> 2) & 1;
    assert_close(pb[8 + c], w4to2[1][cx] * w4to2[2][cy] * w4to2[3][cz], 1e-15);
  }
  assert_close(pb[8 + 4], 0.75 * 0.25 * 1.0, 1e-15); /* cell (0, 0, 1) */
  hetinv_param_map_destroy(&map);

  assert_ok(hetinv_param_map_create_broadcast(m, 2, SS, &map));
  assert_ok(hetinv_param_map_pullback(map, v, pb, 16));
  for (int c = 0; c < 16; ++c) assert_true(pb[c] == (c == 1 + 4 * 2 ? 1.0 : 0.0));
  hetinv_param_map_destroy(&map);

  double full[64];
  assert_ok(hetinv_param_map_create_identity(m, SS, &map));
  assert_ok(hetinv_param_map_pullback(map, v, full, 64));
  for (size_t c = 0; c < 64; ++c) assert_true(full[c] == (c == voxel ? 1.0 : 0.0));
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&m);
}

static void pullback_errors(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 2);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, SA | SS, &map));
  double v[24] = {0}, pb[16];
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_pullback(NULL, v, pb, 16));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_pullback(map, NULL, pb, 16));
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_param_map_pullback(map, v, NULL, 16));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_pullback(map, v, pb, 15));
  assert_message_contains("count is 15");
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_param_map_pullback(map, v, pb, 24));
  assert_ok(hetinv_param_map_pullback(map, v, pb, 16));
  hetinv_param_map_destroy(&map);
  hetinv_medium_destroy(&m);
}

/* A map may be applied to any medium of its grid, including a clone of
 * the one it was made from, and outlives that medium. */
static void map_outlives_its_medium(void **state) {
  hetinv_medium_t *m = make(*state, 2, 2, 1);
  hetinv_param_map_t *map = NULL;
  assert_ok(hetinv_param_map_create_identity(m, SA, &map));
  hetinv_medium_destroy(&m);
  hetinv_medium_t *n = make(*state, 2, 2, 1);
  assert_ok(hetinv_param_map_apply(map, (double[]){1, 2, 3, 4}, 4, n));
  assert_true(hetinv_medium_grid(n, HETINV_PARAM_SIGMA_A)[3] == 4.0);
  hetinv_medium_destroy(&n);
  hetinv_param_map_destroy(&map);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(identity_size_dims_and_entries),
      cmocka_unit_test(every_mask_orders_blocks_sa_ss_g),
      cmocka_unit_test(coarse_size_and_dims),
      cmocka_unit_test(broadcast_size_and_dims),
      cmocka_unit_test(null_map_queries),
      cmocka_unit_test(creation_errors),
      cmocka_unit_test(identity_apply_writes_exactly_pi),
      cmocka_unit_test(coarse_apply_is_trilinear_cell_centred_and_clamped),
      cmocka_unit_test(coarse_apply_uneven_ratios),
      cmocka_unit_test(broadcast_apply_copies_along_the_axis),
      cmocka_unit_test(apply_errors),
      cmocka_unit_test(extract_copies_and_averages),
      cmocka_unit_test(extract_errors),
      cmocka_unit_test(pullback_is_the_adjoint_of_apply),
      cmocka_unit_test(pullback_of_one_voxel),
      cmocka_unit_test(pullback_errors),
      cmocka_unit_test(map_outlives_its_medium),
  };
  return cmocka_run_group_tests(tests, ht_context_setup, ht_context_teardown);
}
