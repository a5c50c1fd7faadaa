/* The medium as the photon loop sees it: extinction, albedo and g per voxel,
 * and exact regular tracking through the piecewise-constant grid. */
#ifndef HV_GRID_H
#define HV_GRID_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "core/compiler.h"
#include "hetinv/medium.h"
#include "hetinv/sampling.h"
#include "transport/path_log.h"

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
  /* Every voxel has the same σt, albedo and g: free flights of the forward
   * pass then skip the voxel stepping (hv_ray_march_uniform). */
  int uniform;
  double inv_sigma_t;    /* uniform: 1/σt (inf for σt = 0) */
} hv_grid_t;

/* Builds the grid of a committed medium; release with hv_grid_release. */
hetinv_result_t hv_grid_build(const hetinv_medium_t *medium, hv_grid_t *out);
void hv_grid_release(hv_grid_t *grid);

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
    if (r->d[a] < 0.0 && f == fl) --i;
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

/* Amanatides–Woo stepping state of a ray in its current voxel: the
 * distance along the ray to the next face on each axis, and between faces.
 * The step's sign is the direction's (an axis that is stepped along has
 * d != 0); it is not stored: set-up is per flight, steps are fewer. */
typedef struct hv_dda {
  double t_next[3], t_delta[3];
} hv_dda_t;

/* Distance along axis a from the ray's position to the face of its voxel
 * ahead (flo, fhi: the voxel's faces on that axis), >= 0. The face is
 * picked by an index, not a branch (d > 0: fhi); the sign of d makes the
 * distance positive, and d = ±0 gives a distance >= 0 or, rounded, 0. */
static inline double hv_face_distance(double p, double d, double flo, double fhi) {
  const double f[2] = {flo, fhi};
  double dist = (f[d > 0.0] - p) * copysign(1.0, d);
  return dist > 0.0 ? dist : 0.0; /* rounding on a voxel face */
}

/* Set-up from the distances to the faces ahead, dist[a] (hv_face_distance).
 * Free of branches: d = 0 gives 1/|d| = inf, and the one undefined product
 * (0·inf, a ray on a face it runs along) becomes inf like the others, by
 * the min. */
static inline void hv_dda_init_dist(const hv_grid_t *g, const hv_ray_t *r, const double dist[3],
                                    hv_dda_t *s) {
  for (int a = 0; a < 3; ++a) {
    double ainv = 1.0 / fabs(r->d[a]);
    double t = dist[a] * ainv;
    s->t_next[a] = t < HUGE_VAL ? t : HUGE_VAL; /* NaN -> inf */
    s->t_delta[a] = g->h[a] * ainv;
  }
}

static inline void hv_dda_init(const hv_grid_t *g, const hv_ray_t *r, hv_dda_t *s) {
  double dist[3];
  for (int a = 0; a < 3; ++a) {
    const double *f = g->face[a] + r->v[a];
    dist[a] = hv_face_distance(r->p[a], r->d[a], f[0], f[1]);
  }
  hv_dda_init_dist(g, r, dist, s);
}

/* The axis whose face the ray reaches first, in integer arithmetic and
 * min, not branches: which axis comes next is a coin toss to a predictor. */
static inline int hv_dda_axis(const hv_dda_t *s) {
  double t0 = s->t_next[0], t1 = s->t_next[1], t2 = s->t_next[2];
  int a = t1 <= t0;
  double m = t0 < t1 ? t0 : t1;
  int b = -(t2 <= m); /* all ones if axis 2 comes first */
  return (a & ~b) | (2 & b);
}

/* Steps into the next voxel along axis a at distance t; returns 0 and puts
 * r->p on the boundary (face in *face) if that leaves the box. */
static inline int hv_dda_advance(const hv_grid_t *g, hv_ray_t *r, hv_dda_t *s, int a, double t,
                                 hetinv_face_t *face) {
  int up = r->d[a] > 0.0;
  int32_t step = 2 * up - 1; /* arithmetic, not a branch: the sign is a coin toss */
  int32_t v = r->v[a] + step;
  if ((uint32_t)v < (uint32_t)g->n[a]) {
    r->v[a] = v;
    r->k += step * g->stride[a];
    s->t_next[a] += s->t_delta[a];
    return 1;
  }
  for (int i = 0; i < 3; ++i) {
    double x = r->p[i] + t * r->d[i];
    r->p[i] = x < g->lo[i] ? g->lo[i] : (x > g->hi[i] ? g->hi[i] : x);
  }
  r->p[a] = up ? g->hi[a] : g->lo[a];
  *face = (hetinv_face_t)(2 * a + up);
  return 0;
}

/* Moves the ray straight to the box's boundary without voxel stepping
 * (uniform grids); r->v and r->k are left as they were. */
static inline void hv_ray_exit_box(const hv_grid_t *g, hv_ray_t *r, double *dist,
                                   hetinv_face_t *face) {
  double tb = HUGE_VAL;
  int ab = 0;
  for (int a = 0; a < 3; ++a) {
    double d = r->d[a];
    double t = d > 0.0 ? (g->hi[a] - r->p[a]) / d : (d < 0.0 ? (g->lo[a] - r->p[a]) / d : HUGE_VAL);
    if (t < tb) {
      tb = t;
      ab = a;
    }
  }
  for (int i = 0; i < 3; ++i) {
    double y = r->p[i] + tb * r->d[i];
    r->p[i] = y < g->lo[i] ? g->lo[i] : (y > g->hi[i] ? g->hi[i] : y);
  }
  r->p[ab] = r->d[ab] > 0.0 ? g->hi[ab] : g->lo[ab];
  *face = (hetinv_face_t)(2 * ab + (r->d[ab] > 0.0 ? 1 : 0));
  *dist = tb < 0.0 ? 0.0 : tb;
}

/* hv_ray_march in a uniform grid: one multiplication, and one predictable
 * test that the collision lies in the box. It leaves r->v and r->k as they
 * were (all voxels are alike); code that needs the voxel re-locates the ray. */
static inline int hv_ray_march_uniform(const hv_grid_t *g, hv_ray_t *r, double depth,
                                       double *dist, hetinv_face_t *face) {
  double x = depth * g->inv_sigma_t;
  double q[3];
  for (int i = 0; i < 3; ++i) q[i] = r->p[i] + x * r->d[i];
  /* The common case, one predictable branch: the collision is inside the box. */
  if ((q[0] >= g->lo[0]) & (q[0] <= g->hi[0]) & (q[1] >= g->lo[1]) & (q[1] <= g->hi[1]) &
      (q[2] >= g->lo[2]) & (q[2] <= g->hi[2])) {
    for (int i = 0; i < 3; ++i) r->p[i] = q[i];
    *dist = x;
    return 1;
  }
  hv_ray_exit_box(g, r, dist, face);
  return 0;
}

/* Free flight: moves the ray until it has crossed optical depth @p depth
 * (returns 1: a collision at r->p) or reaches the boundary (returns 0: r->p
 * on face *face). *dist receives the distance travelled; r->k is the voxel
 * at the end. Segments go to @p log when it is not NULL: one per voxel
 * crossed, of its exact length in that voxel. */
HV_ALWAYS_INLINE static inline int hv_ray_march(const hv_grid_t *g, hv_ray_t *r, double depth,
                                                double *dist, hetinv_face_t *face,
                                                hv_path_log_t *log) {
  if (g->uniform) {
    /* Gradient scores log the straight segment whole; it is split into
     * voxels only if a splat follows it (hv_grad_apply_log). */
    double p0[3] = {r->p[0], r->p[1], r->p[2]};
    int collided = hv_ray_march_uniform(g, r, depth, dist, face);
    if (log) hv_path_log_add_ray(log, p0, r->d, *dist);
    return collided;
  }
  const hv_voxel_t *vx = &g->voxel[r->k];
  /* Most flights end in the voxel they start in (the mean free path is
   * about a voxel): if the collision at x = depth/σt of this voxel comes
   * before every face ahead (x·|d| <= distance to the face, on each axis),
   * that is the flight, with no divisions and no stepping set-up. */
  double x = depth * vx->inv_sigma_t, dist_face[3];
  int in = 1;
  for (int a = 0; a < 3; ++a) {
    const double *f = g->face[a] + r->v[a];
    dist_face[a] = hv_face_distance(r->p[a], r->d[a], f[0], f[1]);
    in &= x * fabs(r->d[a]) <= dist_face[a]; /* false for NaN and inf: vacuum voxels step */
  }
  if (in) {
    if (log) hv_path_log_add(log, HV_LOG_SEGMENT, r->k, x);
    for (int i = 0; i < 3; ++i) r->p[i] += x * r->d[i];
    *dist = x;
    return 1;
  }
  /* The collision lies beyond the first voxel: cross it whole, then test
   * each voxel entered. Should rounding make the two tests disagree, depth
   * ends a hair below 0 and the collision is on the next face. */
  hv_dda_t s;
  hv_dda_init_dist(g, r, dist_face, &s);
  double t = 0.0, st = vx->sigma_t;
  int a = hv_dda_axis(&s);
  double tn = s.t_next[a];
  for (;;) {
    if (log) hv_path_log_add(log, HV_LOG_SEGMENT, r->k, tn - t);
    depth -= st * (tn - t);
    t = tn;
    if (!hv_dda_advance(g, r, &s, a, t, face)) {
      *dist = t;
      return 0;
    }
    vx = &g->voxel[r->k];
    st = vx->sigma_t;
    a = hv_dda_axis(&s);
    tn = s.t_next[a];
    if (st * (tn - t) >= depth) { /* collision inside this voxel */
      x = depth > 0.0 ? depth * vx->inv_sigma_t : 0.0; /* st > 0 if depth > 0 */
      if (log) hv_path_log_add(log, HV_LOG_SEGMENT, r->k, x);
      t += x;
      for (int i = 0; i < 3; ++i) r->p[i] += t * r->d[i];
      *dist = t;
      return 1;
    }
  }
}

/* Moves the ray straight to the boundary; returns the optical depth crossed
 * and sets *dist and *face. */
static inline double hv_ray_to_boundary(const hv_grid_t *g, hv_ray_t *r, double *dist,
                                        hetinv_face_t *face, hv_path_log_t *log) {
  if (g->uniform) {
    double p0[3] = {r->p[0], r->p[1], r->p[2]};
    hv_ray_exit_box(g, r, dist, face);
    if (log) hv_path_log_add_ray(log, p0, r->d, *dist);
    return g->voxel[0].sigma_t * *dist;
  }
  hv_dda_t s;
  hv_dda_init(g, r, &s);
  double t = 0.0, depth = 0.0;
  for (;;) {
    int a = hv_dda_axis(&s);
    double seg = s.t_next[a] - t;
    if (log) hv_path_log_add(log, HV_LOG_SEGMENT, r->k, seg);
    depth += g->voxel[r->k].sigma_t * seg;
    t = s.t_next[a];
    if (!hv_dda_advance(g, r, &s, a, t, face)) {
      *dist = t;
      return depth;
    }
  }
}

#endif
