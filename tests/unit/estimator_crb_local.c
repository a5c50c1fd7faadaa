/* The local Cramér–Rao bound (hetinv_fisher_local_crb): on random symmetric
 * positive definite matrices it equals the full inverse once the window
 * holds every entry, the inverse of each cell's own block at radius 0, and
 * grows with the radius from sqrt(1/F_kk); unseen entries are +inf, a
 * matrix that is not positive definite gives NaN, and bad arguments get
 * precise errors. Exact linear algebra: no Monte Carlo. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "test_support.h"

enum { NX = 4, NZ = 3, CELLS = NX * NZ, K = 3 * CELLS };

typedef struct fixture {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_param_map_t *map;
} fixture_t;

static void fixture_init(fixture_t *f, int32_t nx, int32_t nz) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  assert_ok(hetinv_medium_create(f->ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){nx, 1, nz},
                                 &f->medium));
  assert_ok(hetinv_medium_fill(f->medium, 0.1, 1.0, 0.5));
  assert_ok(hetinv_medium_commit(f->medium));
  assert_ok(hetinv_param_map_create_identity(f->medium, HETINV_FREE_ALL, &f->map));
}

static void fixture_release(fixture_t *f) {
  hetinv_param_map_destroy(&f->map);
  hetinv_medium_destroy(&f->medium);
  hetinv_context_destroy(&f->ctx);
}

/* F = A Aᵀ + 0.05 I with A's entries uniform in [−1, 1) from a fixed LCG. */
static void random_spd(double *F, unsigned seed) {
  static double A[K * K];
  uint64_t x = seed;
  for (int i = 0; i < K * K; ++i) {
    x = x * 6364136223846793005ULL + 1442695040888963407ULL;
    A[i] = (double)(x >> 11) / 9007199254740992.0 * 2.0 - 1.0;
  }
  for (int i = 0; i < K; ++i) {
    for (int j = 0; j < K; ++j) {
      double s = i == j ? 0.05 : 0.0;
      for (int l = 0; l < K; ++l) s += A[i * K + l] * A[j * K + l];
      F[i * K + j] = s;
    }
  }
}

/* diag(M⁻¹) of the m×m submatrix of F on entries idx, by Gauss–Jordan. */
static void inverse_diagonal(const double *F, const size_t *idx, int m, double *out) {
  static double M[K][2 * K];
  for (int i = 0; i < m; ++i) {
    for (int j = 0; j < m; ++j) {
      M[i][j] = F[idx[i] * K + idx[j]];
      M[i][m + j] = i == j;
    }
  }
  for (int c = 0; c < m; ++c) {
    int p = c;
    for (int i = c + 1; i < m; ++i) {
      if (fabs(M[i][c]) > fabs(M[p][c])) p = i;
    }
    for (int j = 0; j < 2 * m; ++j) {
      double t = M[c][j];
      M[c][j] = M[p][j];
      M[p][j] = t;
    }
    double d = M[c][c];
    for (int j = 0; j < 2 * m; ++j) M[c][j] /= d;
    for (int i = 0; i < m; ++i) {
      if (i == c) continue;
      double e = M[i][c];
      for (int j = 0; j < 2 * m; ++j) M[i][j] -= e * M[c][j];
    }
  }
  for (int i = 0; i < m; ++i) out[i] = M[i][m + i];
}

static void close_to(double got, double want) {
  if (!(fabs(got - want) <= 1e-9 * fabs(want))) fail_msg("got %.17g, want %.17g", got, want);
}

static void whole_window_is_the_full_bound(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, NX, NZ);
  static double F[K * K];
  double sd[K], ref[K];
  size_t all[K];
  for (size_t i = 0; i < K; ++i) all[i] = i;
  for (unsigned seed = 1; seed <= 3; ++seed) {
    random_spd(F, seed);
    inverse_diagonal(F, all, K, ref);
    assert_ok(hetinv_fisher_local_crb(f.map, F, K, NX, sd)); /* every cell within NX */
    for (int i = 0; i < K; ++i) close_to(sd[i], sqrt(ref[i]));
  }
  fixture_release(&f);
}

static void radius_zero_is_each_cell_alone(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, NX, NZ);
  static double F[K * K];
  double sd[K], ref[3];
  random_spd(F, 4);
  assert_ok(hetinv_fisher_local_crb(f.map, F, K, 0, sd));
  for (size_t c = 0; c < CELLS; ++c) {
    size_t idx[3] = {c, CELLS + c, 2 * CELLS + c}; /* σa, σs, g of cell c */
    inverse_diagonal(F, idx, 3, ref);
    for (int p = 0; p < 3; ++p) close_to(sd[idx[p]], sqrt(ref[p]));
  }
  fixture_release(&f);
}

static void bound_grows_with_the_radius(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, NX, NZ);
  static double F[K * K];
  double lo[K], hi[K];
  random_spd(F, 5);
  for (int i = 0; i < K; ++i) lo[i] = 1.0 / sqrt(F[i * K + i]);
  for (int32_t r = 0; r <= NX; ++r) {
    assert_ok(hetinv_fisher_local_crb(f.map, F, K, r, hi));
    for (int i = 0; i < K; ++i) assert_true(hi[i] >= lo[i] * (1.0 - 1e-12));
    memcpy(lo, hi, sizeof lo);
  }
  fixture_release(&f);
}

static void unseen_entries_are_infinite_and_indefinite_ones_nan(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, NX, NZ);
  static double F[K * K];
  double sd[K];
  random_spd(F, 6);
  for (int j = 0; j < K; ++j) F[5 * K + j] = F[j * K + 5] = 0.0; /* entry 5: nothing reaches it */
  assert_ok(hetinv_fisher_local_crb(f.map, F, K, 1, sd));
  assert_true(isinf(sd[5]) && sd[5] > 0);
  for (int i = 0; i < K; ++i) assert_true(i == 5 || (isfinite(sd[i]) && sd[i] > 0.0));
  random_spd(F, 7);
  /* σa and σs of cell 0 correlated beyond 1: no window holding cell 0 is
   * positive definite. */
  F[CELLS] = F[CELLS * K] = 2.0 * sqrt(F[0] * F[CELLS * K + CELLS]);
  assert_ok(hetinv_fisher_local_crb(f.map, F, K, 0, sd));
  assert_true(isnan(sd[0]) && isnan(sd[CELLS]) && isnan(sd[2 * CELLS])); /* cell 0's window */
  assert_true(isfinite(sd[1]));
  fixture_release(&f);
}

static void bad_arguments_get_precise_errors(void **state) {
  (void)state;
  fixture_t f;
  fixture_init(&f, NX, NZ);
  static double F[K * K];
  double sd[K];
  random_spd(F, 8);
  assert_int_equal(hetinv_fisher_local_crb(NULL, F, K, 0, sd), HETINV_ERROR_NULL_ARGUMENT);
  assert_int_equal(hetinv_fisher_local_crb(f.map, NULL, K, 0, sd), HETINV_ERROR_NULL_ARGUMENT);
  assert_int_equal(hetinv_fisher_local_crb(f.map, F, K, 0, NULL), HETINV_ERROR_NULL_ARGUMENT);
  assert_int_equal(hetinv_fisher_local_crb(f.map, F, K - 1, 0, sd), HETINV_ERROR_INVALID_ARGUMENT);
  assert_message_contains("the map has 36 entries");
  assert_int_equal(hetinv_fisher_local_crb(f.map, F, K, -1, sd), HETINV_ERROR_INVALID_ARGUMENT);
  assert_message_contains("radius is -1");
  fixture_release(&f);
  /* A window larger than the dense limit is refused before any allocation. */
  fixture_init(&f, 40, 40);
  size_t k = hetinv_param_map_size(f.map);
  assert_int_equal(hetinv_fisher_local_crb(f.map, F, k, 13, sd), HETINV_ERROR_INVALID_ARGUMENT);
  assert_message_contains("windows of 2187 entries");
  fixture_release(&f);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(whole_window_is_the_full_bound),
      cmocka_unit_test(radius_zero_is_each_cell_alone),
      cmocka_unit_test(bound_grows_with_the_radius),
      cmocka_unit_test(unseen_entries_are_infinite_and_indefinite_ones_nan),
      cmocka_unit_test(bad_arguments_get_precise_errors),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
