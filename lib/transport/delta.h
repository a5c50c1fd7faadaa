/* Free flights by delta tracking (Woodcock): tentative collisions at the
 * rate of the majorant σ̄ = max σt, each kept with probability σt(x)/σ̄.
 * The kept collision has exactly the free-flight distribution of regular
 * tracking, 1 - exp(-∫σt), but costs one voxel lookup per tentative
 * collision instead of one step per voxel face: in a medium whose voxels
 * are smaller than a mean free path, or alike, far fewer. It yields no
 * per-voxel segment lengths: a score pass logs the flight whole and steps
 * through it (walk.h) only for a path that reaches a sensor. Since the
 * kept collision has regular tracking's law, so has the path, and its
 * score is that law's. choose_tracking in grid.c decides per grid. */
#ifndef HV_DELTA_H
#define HV_DELTA_H

#include <stdbool.h>
#include <stdint.h>

#include "core/compiler.h"
#include "core/exponential.h"
#include "core/rng.h"
#include "transport/grid.h"
#include "transport/walk.h"

/* The voxel of a point inside the box (or, rounded, on its boundary):
 * truncation is floor there, and a clamp keeps rounding in the grid. */
HV_ALWAYS_INLINE static inline void hv_ray_locate_inside(const hv_grid_t *g, hv_ray_t *r) {
  int64_t k = 0;
  for (int a = 0; a < 3; ++a) {
    int32_t i = (int32_t)((r->p[a] - g->lo[a]) * g->inv_h[a]);
    i = i < 0 ? 0 : (i >= g->n[a] ? g->n[a] - 1 : i);
    r->v[a] = i;
    k += (int64_t)i * g->stride[a];
  }
  r->k = k;
}

/* hv_ray_locate_inside's voxel index alone, for a point q of the box
 * (hv_grid_contains), from the grid's constants copied into a caller's
 * frame: a loop that also stores to random streams (uint32_t, which may
 * alias the grid's int32_t fields) would otherwise reload them after every
 * draw. q ≥ lo makes every coordinate's truncation ≥ 0, so only rounding
 * at the far faces needs the clamp. */
typedef struct hv_locator {
  double lo[3], inv_h[3];
  int32_t last[3]; /* n - 1 */
  int64_t stride[3];
  bool narrow;     /* every linear index fits an int32_t */
} hv_locator_t;

static inline hv_locator_t hv_locator_of(const hv_grid_t *g) {
  hv_locator_t loc;
  for (int a = 0; a < 3; ++a) {
    loc.lo[a] = g->lo[a];
    loc.inv_h[a] = g->inv_h[a];
    loc.last[a] = g->n[a] - 1;
    loc.stride[a] = g->stride[a];
  }
  loc.narrow = g->stride[2] * (int64_t)g->n[2] <= INT32_MAX;
  return loc;
}

HV_ALWAYS_INLINE static inline int64_t hv_voxel_inside(const hv_locator_t *loc, const double q[3]) {
  int64_t k = 0;
  for (int a = 0; a < 3; ++a) {
    int32_t i = (int32_t)((q[a] - loc->lo[a]) * loc->inv_h[a]);
    k += (int64_t)(i <= loc->last[a] ? i : loc->last[a]) * loc->stride[a];
  }
  return k;
}

/* Keeps a tentative collision in voxel k for the draw b (u = b/2^32):
 * u·σ̄ < σt(k). With q = floor(256 σt/σ̄) (rounded), b >> 24 < q - 1 keeps
 * and b >> 24 > q drops with that test's outcome, from a byte; only the
 * 2/256 between read σt and run the test. */
HV_ALWAYS_INLINE static inline int hv_delta_keep(const hv_grid_t *g, int64_t k, uint32_t b) {
  int32_t top = (int32_t)(b >> 24), q = g->sigma_t_q[k];
  return top < q - 1 || (top <= q && hv_unit_from_u32(b) * g->majorant < g->voxel[k].sigma_t);
}

/* hv_ray_march's contract without a log: the first tentative collision is
 * `depth` (an Exp(1) variate) over σ̄; later ones and the acceptance tests
 * draw from rng. r->v and r->k are the voxel at the end (the last one
 * inside on an exit). */
HV_ALWAYS_INLINE static inline int hv_ray_march_delta(const hv_grid_t *g, hv_ray_t *r, double depth,
                                                      const hv_exp_table_t *table, hv_rng_t *rng,
                                                      double *dist, hetinv_face_t *face) {
  double x = depth * g->inv_majorant;
  for (;;) {
    double q[3];
    for (int i = 0; i < 3; ++i) q[i] = r->p[i] + x * r->d[i];
    if (!hv_grid_contains(g, q)) {
      hv_ray_exit_box(g, r, dist, face);
      hv_ray_locate(g, r); /* on the exit face, moving out: the last voxel inside */
      return 0;
    }
    hv_ray_t c = *r;
    for (int i = 0; i < 3; ++i) c.p[i] = q[i];
    hv_ray_locate_inside(g, &c);
    /* The record a kept collision reads next (albedo, g) is rarely in a
     * core's cache: start its load while the test runs. */
    HV_PREFETCH(&g->voxel[c.k]);
    if (hv_delta_keep(g, c.k, hv_rng_u32(rng))) {
      *r = c;
      *dist = x;
      return 1;
    }
    x += hv_exp_sample(table, hv_rng_u64(rng), rng) * g->inv_majorant;
  }
}

#endif
