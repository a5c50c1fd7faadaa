/* The medium as the photon loop sees it: extinction, albedo and g per voxel,
 * and the voxel of a point. Tracking through the grid is walk.h's. */
#ifndef HV_GRID_H
#define HV_GRID_H

#include <math.h>
#include <stddef.h>
#include <stdbool.h>
#include <stdint.h>

#include "core/compiler.h"
#include "hetinv/medium.h"
#include "hetinv/sampling.h"
#include "transport/grid_store.h"

/* What the walk reads of one voxel, packed in one record (32 bytes, two
 * per cache line): a crossing reads σt, a collision 1/σt, a scattering the
 * albedo and g, all from the line the crossing already loaded. Doubles
 * throughout: the medium's own values, no rounding of the physics. */
typedef struct hv_voxel {
  double sigma_t;     /* σa + σs */
  double inv_sigma_t; /* 1/σt (inf where σt = 0) */
  double albedo;      /* σs / σt (0 where σt = 0) */
  double g;
} hv_voxel_t;

typedef struct hv_grid {
  double lo[3], hi[3];
  double h[3], inv_h[3]; /* voxel size and its inverse */
  int32_t n[3];
  int64_t stride[3];     /* linear-index step per axis: 1, nx, nx·ny */
  hv_voxel_t *voxel;     /* in linear voxel order */
  /* Coordinates of the voxel faces along each axis, face[a][i] = lo + i·h
   * for i = 0..n[a]: the walk's voxel bounds, one load instead of a
   * conversion, a multiplication and an addition, and the same value
   * wherever a face is needed. */
  const double *face[3];
  double *face_storage;
  const double *sigma_s; /* the medium's own array (gradient scores need σs) */
  double eta, eta_out;
  const hetinv_context_t *ctx;
  bool borrowed; /* voxel and sigma_t_q are a store's (grid_store.h), not freed with the grid */
  /* Every voxel has the same σt, albedo and g: free flights of the forward
   * pass then skip the voxel stepping (hv_ray_march_uniform). */
  int uniform;
  double inv_sigma_t;    /* uniform: 1/σt (inf for σt = 0) */
  /* Every voxel has voxel[0]'s g (uniform or not): a scattering's phase
   * sampling needs no per-voxel g, and the lanes keep its constants. */
  int uniform_g;
  /* Every pass samples a non-uniform grid's free flights by delta tracking
   * against the majorant σ̄ = max σt when that is cheaper than stepping
   * voxel by voxel (grid.c: choose_tracking). Score passes log such a
   * flight whole and step through it only if a splat follows it
   * (hv_grad_apply_log): the score needs each voxel's segment. */
  int delta;
  double majorant, inv_majorant;
  /* delta: per voxel, q = floor(256 σt/σ̄) clamped to 255, one byte: the
   * acceptance test reads it (a megabyte per million voxels stays in a
   * core's cache, the 32-byte records do not) and reads σt only when its
   * draw falls within 2/256 of q/256, so the test's outcome is the exact
   * one. NULL unless delta. */
  uint8_t *sigma_t_q;
  /* Optical depth along an axis from a voxel to the box, per direction of
   * travel (index 2a + up, as hetinv_face_t): axis_depth[f][k] is
   * Σ σt·h[a] over the voxels beyond k toward face f; NULL unless built
   * (hv_grid_build_axis_depths). A walk to the boundary along an axis is
   * then one lookup: an orthographic camera looking along a face normal
   * connects every scattering vertex to its face along one. */
  const double *axis_depth[6];
  double *axis_depth_storage;
} hv_grid_t;

/* Builds the grid of a committed medium, its per-voxel arrays in slot 0
 * of `store` (kept there for the next build) or, with store NULL, its own;
 * release with hv_grid_release. */
hetinv_result_t hv_grid_build(const hetinv_medium_t *medium, hv_grid_store_t *store, hv_grid_t *out);
void hv_grid_release(hv_grid_t *grid);

/* A copy of g whose per-voxel records and acceptance bytes are slot i
 * (≥ 1) of store, everything else shared with g, for one thread to read:
 * two cores reading the same lines of arrays larger than their caches
 * serve each other's misses (docs/results/kernel.md). hv_grid_copy_take
 * takes the slot (false if memory ran out); hv_grid_copy_fill copies g's
 * values in, on the thread that will read them, so that a new slot's
 * pages are first touched there and the copies are made in parallel.
 * Nothing to release: the store keeps the slot. */
bool hv_grid_copy_take(const hv_grid_t *g, hv_grid_store_t *store, int i, hv_grid_t *copy);
void hv_grid_copy_fill(const hv_grid_t *g, hv_grid_t *copy);
/* The bytes of one copy's arrays (hv_grid_copy_take). */
size_t hv_grid_voxel_bytes(const hv_grid_t *g);

/* Builds axis_depth[f] for every face f in the bit mask `faces` (bit f);
 * 8 bytes per voxel each. A uniform grid needs none (its walks are one
 * multiplication) and gets none. */
hetinv_result_t hv_grid_build_axis_depths(hv_grid_t *grid, uint32_t faces);

/* Whether q lies in the box, its faces included (no branch per axis). */
static inline int hv_grid_contains(const hv_grid_t *g, const double q[3]) {
  return (q[0] >= g->lo[0]) & (q[0] <= g->hi[0]) & (q[1] >= g->lo[1]) & (q[1] <= g->hi[1]) & (q[2] >= g->lo[2]) &
         (q[2] <= g->hi[2]);
}

/* A ray being tracked: position, unit direction, and its voxel. */
typedef struct hv_ray {
  double p[3], d[3];
  int32_t v[3]; /* voxel coordinates */
  int64_t k;    /* linear voxel index */
} hv_ray_t;

/* Voxel of position p (inside or on the boundary) for travel along d: a
 * point on a voxel face belongs to the voxel the ray is entering. In a
 * uniform grid the forward pass never needs it: the voxel of a vertex is
 * found only when a gradient score must be attributed (hv_vertex_voxel). */
static inline void hv_ray_locate(const hv_grid_t *g, hv_ray_t *r) {
  r->k = 0;
  for (int a = 0; a < 3; ++a) {
    double f = (r->p[a] - g->lo[a]) * g->inv_h[a];
    double fl = floor(f);
    int32_t i = (int32_t)fl;
    i -= (r->d[a] < 0.0) & (f == fl); /* on a face, moving down: the voxel below; no branch on the sign */
    i = i < 0 ? 0 : (i >= g->n[a] ? g->n[a] - 1 : i);
    r->v[a] = i;
    r->k += (int64_t)i * g->stride[a];
  }
}

/* Linear index of the voxel holding the scattering vertex r, which a
 * uniform grid's free flights do not keep up to date. */
static inline int64_t hv_vertex_voxel(const hv_grid_t *g, const hv_ray_t *r) {
  if (!g->uniform) return r->k;
  hv_ray_t q = *r;
  hv_ray_locate(g, &q);
  return q.k;
}

#endif
