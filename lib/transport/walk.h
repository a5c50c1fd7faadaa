/* Exact regular tracking through the voxel grid (Amanatides–Woo): free
 * flights, walks to the boundary, and the voxel-by-voxel split of a
 * straight segment that gradient scores need.
 *
 * The walk keeps its state in scalars, one per axis, and picks the axis
 * of the next face with compares and selects: which face comes next is a
 * coin toss to a branch predictor, and state indexed by that axis (an
 * array t_next[a], v[a]) sits in memory, so every crossing paid a store
 * and a dependent load. Per crossing the walk does the arithmetic of the
 * textbook algorithm and no more, in the same order, so segment lengths
 * are bitwise those of the indexed version it replaced. */
#ifndef HV_WALK_H
#define HV_WALK_H

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "core/bits.h"
#include "core/compiler.h"
#include "transport/grid.h"
#include "transport/path_log.h"

/* Distance along axis a from the ray's position to the face of its voxel
 * ahead (face[0], face[1]: the voxel's faces on that axis, in the grid's
 * face array), >= 0. The face is picked by an index, not a branch (d > 0:
 * face[1]), and loaded from the array by it: a pair copied into a local
 * array first cost a store and a reload per axis. The sign of d makes the
 * distance positive, and d = ±0 gives a distance >= 0 or, rounded, 0. */
static inline double hv_face_distance(double p, double d, const double *face) {
  double dist = (face[d > 0.0] - p) * copysign(1.0, d);
  return dist > 0.0 ? dist : 0.0; /* rounding on a voxel face */
}

/* A ray's walk from voxel to voxel. t*: distance along the ray to the next
 * face on each axis; dt*: between faces (inf along an axis the ray does not
 * move on); s*: the linear-index step of a crossing; left*: crossings left
 * on that axis before the box's face; sel*: the axis hv_walk_next picked,
 * as 0/1 (exactly one is 1). */
typedef struct hv_walk {
  double t0, t1, t2, dt0, dt1, dt2;
  int64_t s0, s1, s2, k;
  int32_t left0, left1, left2;
  int32_t sel0, sel1, sel2;
} hv_walk_t;

/* Set-up from the distances to the faces ahead, dist[a] (hv_face_distance).
 * d = 0 gives 1/|d| = inf, and the one undefined product (0·inf, a ray on a
 * face it runs along) becomes inf like the others. */
static inline void hv_walk_init_dist(const hv_grid_t *g, const hv_ray_t *r, const double dist[3],
                                     hv_walk_t *w) {
  double tn[3], dt[3];
  int64_t s[3];
  int32_t left[3];
  for (int a = 0; a < 3; ++a) {
    double ainv = 1.0 / fabs(r->d[a]);
    double t = dist[a] * ainv;
    tn[a] = t < HUGE_VAL ? t : HUGE_VAL; /* NaN -> inf */
    dt[a] = g->h[a] * ainv;
    /* By masks: the sign of d is a coin toss to a branch predictor. */
    int32_t up = r->d[a] > 0.0;
    int64_t down = (int64_t)up - 1; /* 0 or all ones */
    s[a] = (g->stride[a] ^ down) - down;
    left[a] = r->v[a] + (-up & (g->n[a] - 1 - 2 * r->v[a]));
  }
  *w = (hv_walk_t){.t0 = tn[0], .t1 = tn[1], .t2 = tn[2], .dt0 = dt[0], .dt1 = dt[1], .dt2 = dt[2],
                   .s0 = s[0], .s1 = s[1], .s2 = s[2], .k = r->k,
                   .left0 = left[0], .left1 = left[1], .left2 = left[2]};
}

static inline void hv_walk_init(const hv_grid_t *g, const hv_ray_t *r, hv_walk_t *w) {
  double dist[3];
  for (int a = 0; a < 3; ++a) {
    const double *f = g->face[a] + r->v[a];
    dist[a] = hv_face_distance(r->p[a], r->d[a], f);
  }
  hv_walk_init_dist(g, r, dist, w);
}

/* Picks the axis whose face comes first and returns its distance. Ties go
 * to the higher axis. */
HV_ALWAYS_INLINE static inline double hv_walk_next(hv_walk_t *w) {
  int32_t one = w->t1 <= w->t0;
  double m = w->t0 < w->t1 ? w->t0 : w->t1;
  int32_t two = w->t2 <= m;
  w->sel2 = two;
  w->sel1 = one & !two;
  w->sel0 = !one & !two;
  return two ? w->t2 : m;
}

/* The axis hv_walk_next picked. */
static inline int hv_walk_axis(const hv_walk_t *w) { return w->sel2 ? 2 : w->sel1; }

/* Crosses the face hv_walk_next picked: 1 and the next voxel, or 0 (state
 * unchanged) if that face is the box's. */
HV_ALWAYS_INLINE static inline int hv_walk_cross(hv_walk_t *w) {
  int32_t out = (w->sel0 & (w->left0 == 0)) | (w->sel1 & (w->left1 == 0)) | (w->sel2 & (w->left2 == 0));
  if (out) return 0;
  w->left0 -= w->sel0;
  w->left1 -= w->sel1;
  w->left2 -= w->sel2;
  w->k += (w->s0 & -(int64_t)w->sel0) + (w->s1 & -(int64_t)w->sel1) + (w->s2 & -(int64_t)w->sel2);
  /* t_next[a] += t_delta[a]; the other axes add +0, which changes no
   * distance (all are >= 0 or inf). Masks, not selects: a compiler turns a
   * select of three into branches on the axis. */
  w->t0 += hv_keep_if(w->dt0, (uint32_t)w->sel0);
  w->t1 += hv_keep_if(w->dt1, (uint32_t)w->sel1);
  w->t2 += hv_keep_if(w->dt2, (uint32_t)w->sel2);
  return 1;
}

/* Writes the walk's voxel back into the ray. */
static inline void hv_walk_store(const hv_grid_t *g, const hv_walk_t *w, hv_ray_t *r) {
  const int32_t left[3] = {w->left0, w->left1, w->left2};
  for (int a = 0; a < 3; ++a) {
    int32_t up = r->d[a] > 0.0; /* by a mask, as in hv_walk_init_dist */
    r->v[a] = left[a] + (-up & (g->n[a] - 1 - 2 * left[a]));
  }
  r->k = w->k;
}

/* The ray leaves the box through the face hv_walk_next picked, at distance
 * t: r->p on the boundary, the face in *face, r->v and r->k the last voxel
 * inside. */
static inline void hv_walk_leave(const hv_grid_t *g, const hv_walk_t *w, hv_ray_t *r, double t,
                                 hetinv_face_t *face) {
  int a = hv_walk_axis(w);
  int up = r->d[a] > 0.0;
  hv_walk_store(g, w, r);
  for (int i = 0; i < 3; ++i) {
    double x = r->p[i] + t * r->d[i];
    r->p[i] = x < g->lo[i] ? g->lo[i] : (x > g->hi[i] ? g->hi[i] : x);
  }
  r->p[a] = up ? g->hi[a] : g->lo[a];
  *face = (hetinv_face_t)(2 * a + up);
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
    dist_face[a] = hv_face_distance(r->p[a], r->d[a], f);
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
  hv_walk_t w;
  hv_walk_init_dist(g, r, dist_face, &w);
  double t = 0.0, st = vx->sigma_t;
  double tn = hv_walk_next(&w);
  for (;;) {
    if (log) hv_path_log_add(log, HV_LOG_SEGMENT, w.k, tn - t);
    depth -= st * (tn - t);
    t = tn;
    if (!hv_walk_cross(&w)) {
      hv_walk_leave(g, &w, r, t, face);
      *dist = t;
      return 0;
    }
    vx = &g->voxel[w.k];
    st = vx->sigma_t;
    tn = hv_walk_next(&w);
    if (st * (tn - t) >= depth) { /* collision inside this voxel */
      x = depth > 0.0 ? depth * vx->inv_sigma_t : 0.0; /* st > 0 if depth > 0 */
      if (log) hv_path_log_add(log, HV_LOG_SEGMENT, w.k, x);
      t += x;
      hv_walk_store(g, &w, r);
      for (int i = 0; i < 3; ++i) r->p[i] += t * r->d[i];
      *dist = t;
      return 1;
    }
  }
}

/* The axis a ray runs along, or -1 if it moves on more than one. */
static inline int hv_ray_axis(const hv_ray_t *r) {
  int moving = (r->d[0] != 0.0) + (r->d[1] != 0.0) + (r->d[2] != 0.0);
  if (moving != 1) return -1;
  return r->d[0] != 0.0 ? 0 : (r->d[1] != 0.0 ? 1 : 2);
}

/* hv_ray_to_boundary along axis a, whose table g->axis_depth[2a + up] is
 * built: the rest of the line's optical depth is one lookup. The segments
 * logged are the walk's: the part of the first voxel ahead, then h[a] per
 * voxel (divided by |d[a]|, 1 for a unit ray). */
static inline double hv_ray_to_boundary_axis(const hv_grid_t *g, hv_ray_t *r, int a, double *dist,
                                             hetinv_face_t *face, hv_path_log_t *log) {
  int up = r->d[a] > 0.0;
  int f = 2 * a + up;
  double ainv = 1.0 / fabs(r->d[a]);
  const double *fa = g->face[a] + r->v[a];
  double first = hv_face_distance(r->p[a], r->d[a], fa) * ainv;
  int64_t k = r->k;
  double depth = g->voxel[k].sigma_t * first + g->axis_depth[f][k] * ainv;
  int32_t last = up ? g->n[a] - 1 : 0, left = up ? last - r->v[a] : r->v[a];
  int64_t step = up ? g->stride[a] : -g->stride[a];
  if (log) {
    double seg = g->h[a] * ainv;
    hv_path_log_add(log, HV_LOG_SEGMENT, k, first);
    for (int32_t i = 0; i < left; ++i) hv_path_log_add(log, HV_LOG_SEGMENT, k += step, seg);
  } else {
    k += left * step;
  }
  double bound = up ? g->hi[a] : g->lo[a];
  *dist = fabs(bound - r->p[a]) * ainv;
  r->p[a] = bound;
  r->v[a] = last;
  r->k = k;
  *face = (hetinv_face_t)f;
  return depth;
}

/* Moves the ray straight to the boundary; returns the optical depth crossed
 * and sets *dist and *face. */
HV_ALWAYS_INLINE static inline double hv_ray_to_boundary(const hv_grid_t *g, hv_ray_t *r,
                                                         double *dist, hetinv_face_t *face,
                                                         hv_path_log_t *log) {
  if (g->uniform) {
    double p0[3] = {r->p[0], r->p[1], r->p[2]};
    hv_ray_exit_box(g, r, dist, face);
    if (log) hv_path_log_add_ray(log, p0, r->d, *dist);
    return g->voxel[0].sigma_t * *dist;
  }
  int a = hv_ray_axis(r);
  if (a >= 0 && g->axis_depth[2 * a + (r->d[a] > 0.0)]) {
    return hv_ray_to_boundary_axis(g, r, a, dist, face, log);
  }
  hv_walk_t w;
  hv_walk_init(g, r, &w);
  double t = 0.0, depth = 0.0;
  for (;;) {
    double tn = hv_walk_next(&w);
    double seg = tn - t;
    if (log) hv_path_log_add(log, HV_LOG_SEGMENT, w.k, seg);
    depth += g->voxel[w.k].sigma_t * seg;
    t = tn;
    if (!hv_walk_cross(&w)) {
      hv_walk_leave(g, &w, r, t, face);
      *dist = t;
      return depth;
    }
  }
}

/* Splits the straight segment of length `length` from the located ray r
 * into voxels: visit(user, k, length inside voxel k) for each voxel crossed,
 * in order; leaves r->v and r->k at the voxel where the segment ends and
 * returns r->k. Inlined with a constant visit, which is then inlined too. */
HV_ALWAYS_INLINE static inline int64_t hv_walk_segment(const hv_grid_t *g, hv_ray_t *r,
                                                       double length,
                                                       void (*visit)(void *, int64_t, double),
                                                       void *user) {
  /* Most segments of a path end in the voxel they start in (a free flight
   * is about a voxel long): that test needs no divisions, the walk's
   * set-up three. */
  double dist[3];
  int in = 1;
  for (int a = 0; a < 3; ++a) {
    const double *f = g->face[a] + r->v[a];
    dist[a] = hv_face_distance(r->p[a], r->d[a], f);
    in &= length * fabs(r->d[a]) <= dist[a];
  }
  if (in) {
    if (length > 0.0) visit(user, r->k, length);
    return r->k;
  }
  hv_walk_t w;
  hv_walk_init_dist(g, r, dist, &w);
  for (double t = 0.0; t < length;) {
    double tn = hv_walk_next(&w);
    double end = tn < length ? tn : length;
    visit(user, w.k, end - t);
    t = end;
    if (t >= length || !hv_walk_cross(&w)) break;
  }
  hv_walk_store(g, &w, r);
  return r->k;
}

/* Splits a log's RAY entry into voxels (hv_walk_segment). *end is the voxel
 * where the log's previous RAY entry ended (end->k < 0: none, or not split)
 * and becomes this one's. A log's RAY entries are one continuous path: each
 * starts at the scattering vertex or the boundary point where the last one
 * ended, so it starts in that voxel and only a log's first ray is located
 * (three floors and clamps). Where the vertex lies on a face (or within
 * rounding of one), the walk then starts on that face with a zero-length
 * segment, or one a rounding longer, instead of on the other side. */
HV_ALWAYS_INLINE static inline int64_t hv_walk_log_ray(const hv_grid_t *g, const hv_log_entry_t *e,
                                                       hv_ray_t *end,
                                                       void (*visit)(void *, int64_t, double),
                                                       void *user) {
  hv_ray_t r;
  memcpy(r.p, e->u.ray.p, sizeof r.p);
  memcpy(r.d, e->u.ray.d, sizeof r.d);
  if (end->k < 0) {
    hv_ray_locate(g, &r);
  } else {
    memcpy(r.v, end->v, sizeof r.v);
    r.k = end->k;
  }
  hv_walk_segment(g, &r, e->u.ray.length, visit, user);
  memcpy(end->v, r.v, sizeof r.v);
  end->k = r.k;
  return r.k;
}

#endif
