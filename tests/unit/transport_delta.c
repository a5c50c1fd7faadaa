/* Delta tracking (lib/transport/delta.h) against the exact free-flight
 * law of regular tracking. Along a ray, a flight ends at distance s with
 * P(s' <= s) = 1 - exp(-τ(s)), τ the optical depth the reference walk
 * (transport_walk's) accumulates; so V = 1 - exp(-τ(s)) of a collision,
 * and 1 - exp(-τ_exit)·(1 - W) (W uniform) of an exit, is uniform on
 * [0, 1). Its histogram over many flights of many rays, in a grid with
 * vacuum voxels, is tested by χ² at the 10⁻⁴ level, and the number of
 * exits against its binomial expectation within 4 standard deviations. Also: the byte test of
 * a tentative collision decides as the exact comparison for every voxel
 * and draw near its threshold; the state a flight leaves (position, voxel,
 * face) is consistent; and the cost model picks delta tracking for a
 * medium like the benchmark's and stepping for a dense inclusion.
 * Runs in well under a second. */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "test_support.h"
#include "tracking_reference.h"

#include "core/exponential.h"
#include "core/rng.h"
#include "medium/medium_internal.h"
#include "sampling/geometry.h"
#include "transport/delta.h"
#include "transport/grid.h"

enum { RAYS = 500, FLIGHTS = 2000, BINS = 20 };

/* Optical depth along p + t·d for t in [0, s]: the reference's pieces. */
static double reference_depth(const hv_grid_t *g, const double p[3], const double d[3], double s) {
  seg_t seg[MAX_SEG];
  int n = reference_segments(g, p, d, s, seg);
  double depth = 0.0;
  for (int i = 0; i < n; ++i) depth += g->voxel[seg[i].k].sigma_t * seg[i].length;
  return depth;
}

/* A grid of dims voxels in [LO, HI] with these σa, σs. */
static void grid_fixture_make(fixture_t *f, const int32_t dims[3], const double *sa, const double *ss) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  assert_ok(hetinv_medium_create(f->ctx, LO, HI, dims, &f->medium));
  size_t n = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
  assert_ok(hetinv_medium_fill(f->medium, 1.0, 1.0, 0.3));
  assert_ok(hetinv_medium_set_grid(f->medium, HETINV_PARAM_SIGMA_A, sa, n));
  assert_ok(hetinv_medium_set_grid(f->medium, HETINV_PARAM_SIGMA_S, ss, n));
  assert_ok(hetinv_medium_commit(f->medium));
  assert_ok(hv_grid_build(f->medium, NULL, &f->grid));
}

/* The state a flight leaves: a collision at p + s·d in the voxel r->k
 * holds; an exit on face's plane, r->k the voxel inside next to it. */
static void check_state(const hv_grid_t *g, const hv_ray_t *r, const double p[3], const double d[3],
                        double s, int collided, hetinv_face_t face) {
  for (int a = 0; a < 3; ++a) {
    assert_true(fabs(r->p[a] - (p[a] + s * d[a])) <= 1e-12 * (1.0 + fabs(p[a])));
    int32_t v = r->v[a];
    assert_true(v >= 0 && v < g->n[a]);
    assert_true(r->p[a] >= g->face[a][v] - 1e-12 && r->p[a] <= g->face[a][v + 1] + 1e-12);
  }
  assert_true(r->k == r->v[0] * g->stride[0] + r->v[1] * g->stride[1] + r->v[2] * g->stride[2]);
  if (!collided) {
    int a = hv_face_axis(face);
    assert_true(r->p[a] == ((int)face & 1 ? g->hi[a] : g->lo[a]));
    assert_true(fabs(s - exit_distance(g, p, d)) <= 1e-12);
  }
}

static void flights_follow_the_exact_law(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x13198a2e03707344);
  fixture_t f;
  fixture_make(&f, &seed);
  assert_true(f.grid.delta);
  hv_exp_table_t table;
  hv_exp_table_init(&table);
  double count[BINS] = {0}, exit_mean = 0.0, exit_var = 0.0;
  int exits = 0;
  for (int i = 0; i < RAYS; ++i) {
    double p[3], d[3];
    for (int a = 0; a < 3; ++a) p[a] = LO[a] + (HI[a] - LO[a]) * uniform(&seed);
    random_direction(&seed, d);
    double tau_exit = reference_depth(&f.grid, p, d, exit_distance(&f.grid, p, d));
    double p_exit = exp(-tau_exit);
    exit_mean += FLIGHTS * p_exit;
    exit_var += FLIGHTS * p_exit * (1.0 - p_exit);
    for (int j = 0; j < FLIGHTS; ++j) {
      hv_rng_t rng = hv_rng_init(UINT64_C(0xde17a), (uint32_t)i, (uint64_t)j, 0);
      hv_ray_t r = {.p = {p[0], p[1], p[2]}, .d = {d[0], d[1], d[2]}};
      hv_ray_locate(&f.grid, &r);
      double depth = hv_exp_sample(&table, hv_rng_u64(&rng), &rng), s;
      hetinv_face_t face = HETINV_FACE_X_MIN;
      int collided = hv_ray_march_delta(&f.grid, &r, depth, &table, &rng, &s, &face);
      check_state(&f.grid, &r, p, d, s, collided, face);
      double v = collided ? -expm1(-reference_depth(&f.grid, p, d, s))
                          : 1.0 - exp(-tau_exit) * (1.0 - uniform(&seed));
      exits += !collided;
      int bin = (int)(v * BINS);
      count[bin < BINS ? bin : BINS - 1] += 1.0;
    }
  }
  double n = (double)RAYS * FLIGHTS, expect = n / BINS, chi2 = 0.0;
  for (int b = 0; b < BINS; ++b) chi2 += (count[b] - expect) * (count[b] - expect) / expect;
  /* χ² with 19 degrees of freedom exceeds 50.3 with probability 1e-4. */
  /* The exits alone: a sum of Bernoulli(exp(-τ_exit)) per ray. */
  double z = (exits - exit_mean) / sqrt(exit_var);
  print_message("chi2 %.1f over %d bins; %d of %.0f flights left the box, %.1f expected (z %+.2f)\n", chi2,
                BINS, exits, n, exit_mean, z);
  assert_true(chi2 < 50.3);
  assert_true(fabs(z) < 4.0);
  fixture_free(&f);
}

static void byte_test_decides_as_the_comparison(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0xa4093822299f31d0);
  fixture_t f;
  fixture_make(&f, &seed);
  assert_true(f.grid.delta);
  const hv_grid_t *g = &f.grid;
  for (int64_t k = 0; k < NX * NY * NZ; ++k) {
    for (uint32_t top = 0; top < 256; ++top) {
      const uint32_t lows[] = {0, 1, 0x7fffff, 0x800000, 0xfffffe, 0xffffff, (uint32_t)next_u64(&seed) & 0xffffff};
      for (size_t i = 0; i < sizeof lows / sizeof lows[0]; ++i) {
        uint32_t b = top << 24 | lows[i];
        int exact = hv_unit_from_u32(b) * g->majorant < g->voxel[k].sigma_t;
        assert_int_equal(hv_delta_keep(g, k, b), exact);
      }
    }
  }
  fixture_free(&f);
}

static void cost_model_picks_the_cheaper(void **state) {
  (void)state;
  const int32_t dims[3] = {NX, NY, NZ};
  double sa[NX * NY * NZ], ss[NX * NY * NZ];
  fixture_t f;
  /* Voxels of 0.2-0.5 mm, a 1 mm mean free path, ±50 %: few tentative
   * collisions per voxel face. */
  for (size_t i = 0; i < NX * NY * NZ; ++i) {
    sa[i] = 0.1 * (0.5 + (double)(i % 3) * 0.5);
    ss[i] = 0.9 * (0.5 + (double)(i % 5) * 0.25);
  }
  grid_fixture_make(&f, dims, sa, ss);
  assert_true(f.grid.delta);
  assert_non_null(f.grid.sigma_t_q);
  fixture_free(&f);
  /* One voxel 1000 times denser: tentative collisions everywhere at its
   * rate would cost hundreds per voxel crossed. */
  sa[17] = 1000.0;
  grid_fixture_make(&f, dims, sa, ss);
  assert_false(f.grid.delta);
  assert_null(f.grid.sigma_t_q);
  fixture_free(&f);
  /* A uniform grid has its own fast path. */
  for (size_t i = 0; i < NX * NY * NZ; ++i) sa[i] = ss[i] = 1.0;
  grid_fixture_make(&f, dims, sa, ss);
  assert_true(f.grid.uniform);
  assert_false(f.grid.delta);
  fixture_free(&f);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(flights_follow_the_exact_law),
      cmocka_unit_test(byte_test_decides_as_the_comparison),
      cmocka_unit_test(cost_model_picks_the_cheaper),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
