/* What the tracking tests share (transport_walk.c, transport_delta.c): a
 * reproducible generator, the random heterogeneous grid with vacuum voxels
 * they track through, and the brute-force reference of a straight ray's
 * voxels: every face crossing found axis by axis and sorted. */
#ifndef HETINV_TEST_TRACKING_REFERENCE_H
#define HETINV_TEST_TRACKING_REFERENCE_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "test_support.h"

#include "medium/medium_internal.h"
#include "transport/grid.h"

enum { NX = 7, NY = 5, NZ = 6, MAX_SEG = 64 };

static const double LO[3] = {-1.0, 0.25, 2.0}, HI[3] = {2.5, 1.5, 3.2};

/* splitmix64: reproducible draws without the library's generator. */
static uint64_t next_u64(uint64_t *s) {
  uint64_t z = (*s += UINT64_C(0x9e3779b97f4a7c15));
  z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
  z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
  return z ^ (z >> 31);
}

static double uniform(uint64_t *s) { return (double)(next_u64(s) >> 11) * 0x1p-53; }

typedef struct fixture {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hv_grid_t grid;
} fixture_t;

/* σa, σs random per voxel, one voxel in seven a vacuum. */
static void fixture_make(fixture_t *f, uint64_t *seed) {
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  assert_ok(hetinv_context_create(&init, &f->ctx));
  const int32_t dims[3] = {NX, NY, NZ};
  assert_ok(hetinv_medium_create(f->ctx, LO, HI, dims, &f->medium));
  size_t n = NX * NY * NZ;
  double sa[NX * NY * NZ], ss[NX * NY * NZ];
  for (size_t i = 0; i < n; ++i) {
    bool vacuum = next_u64(seed) % 7 == 0;
    sa[i] = vacuum ? 0.0 : 0.1 + 2.0 * uniform(seed);
    ss[i] = vacuum ? 0.0 : 0.1 + 8.0 * uniform(seed);
  }
  assert_ok(hetinv_medium_fill(f->medium, 1.0, 1.0, 0.3));
  assert_ok(hetinv_medium_set_grid(f->medium, HETINV_PARAM_SIGMA_A, sa, n));
  assert_ok(hetinv_medium_set_grid(f->medium, HETINV_PARAM_SIGMA_S, ss, n));
  assert_ok(hetinv_medium_commit(f->medium));
  assert_ok(hv_grid_build(f->medium, NULL, &f->grid));
  assert_false(f->grid.uniform);
}

static void fixture_free(fixture_t *f) {
  hv_grid_release(&f->grid);
  hetinv_medium_destroy(&f->medium);
  hetinv_context_destroy(&f->ctx);
}

typedef struct seg {
  int64_t k;
  double length;
} seg_t;

/* The voxels the ray p + t·d (0 <= t <= t_max, inside the box) crosses, by
 * sorting every face crossing; zero-length pieces dropped. */
static int reference_segments(const hv_grid_t *g, const double p[3], const double d[3],
                              double t_max, seg_t out[MAX_SEG]) {
  double ts[3 * 16 + 2];
  int n = 0;
  ts[n++] = 0.0;
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0.0) continue;
    for (int i = 0; i <= g->n[a]; ++i) {
      double t = (g->face[a][i] - p[a]) / d[a];
      if (t > 0.0 && t < t_max) ts[n++] = t;
    }
  }
  ts[n++] = t_max;
  for (int i = 1; i < n; ++i) { /* insertion sort: a few dozen values */
    for (int j = i; j > 0 && ts[j] < ts[j - 1]; --j) {
      double x = ts[j];
      ts[j] = ts[j - 1];
      ts[j - 1] = x;
    }
  }
  int count = 0;
  for (int i = 1; i < n; ++i) {
    double len = ts[i] - ts[i - 1];
    if (len < 1e-12) continue;
    double tm = 0.5 * (ts[i] + ts[i - 1]);
    int64_t k = 0;
    for (int a = 0; a < 3; ++a) {
      int32_t v = (int32_t)floor((p[a] + tm * d[a] - g->lo[a]) / g->h[a]);
      v = v < 0 ? 0 : (v >= g->n[a] ? g->n[a] - 1 : v);
      k += v * g->stride[a];
    }
    assert_true(count < MAX_SEG);
    out[count++] = (seg_t){k, len};
  }
  return count;
}

/* Distance from p along d to the box's boundary. */
static double exit_distance(const hv_grid_t *g, const double p[3], const double d[3]) {
  double t = HUGE_VAL;
  for (int a = 0; a < 3; ++a) {
    if (d[a] > 0.0) t = fmin(t, (g->hi[a] - p[a]) / d[a]);
    if (d[a] < 0.0) t = fmin(t, (g->lo[a] - p[a]) / d[a]);
  }
  return t;
}

/* A direction uniform on the sphere. */
static void random_direction(uint64_t *s, double d[3]) {
  double z = 2.0 * uniform(s) - 1.0, phi = 6.283185307179586 * uniform(s);
  double rho = sqrt(1.0 - z * z);
  d[0] = rho * cos(phi);
  d[1] = rho * sin(phi);
  d[2] = z;
}

#endif
