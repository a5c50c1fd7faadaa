#include "transport/lanes.h"

#include <math.h>
#include <stdint.h>

#include "core/alloc.h"
#include "core/compiler.h"
#include "transport/delta.h"
#include "transport/photon.h"
#include "transport/walk.h"

/* GCC's and clang's generic vectors: four doubles, four 64-bit masks (all
 * ones or zero per lane), four 32-bit integers. Each operation is IEEE's on
 * every lane, so a lane computes exactly what the scalar expression does
 * when the operations come in the same order (contraction is off); the
 * x86-64-v3 clone makes them AVX2 instructions, the baseline SSE2 pairs. */
#if defined(__GNUC__) || defined(__clang__)
/* Every function here that takes or returns a vector is static and
 * inlined: no vector crosses a call, so the AVX calling convention the
 * warning is about never applies. */
#pragma GCC diagnostic ignored "-Wpsabi"
#endif
typedef double v4d __attribute__((vector_size(32)));
typedef int64_t v4m __attribute__((vector_size(32)));
typedef uint64_t v4u __attribute__((vector_size(32)));
typedef int32_t v4i __attribute__((vector_size(16)));

enum {
  LANES = 4,
  /* Photons finished but not yet added to the tally, at most: a photon
   * waits while an earlier one is still in flight. 64 records keep four
   * lanes busy past all but the longest paths. */
  RING = 64
};

HV_ALWAYS_INLINE static inline v4d splat(double x) { return (v4d){x, x, x, x}; }
HV_ALWAYS_INLINE static inline v4d pick(v4m m, v4d a, v4d b) { return (v4d)(((v4m)a & m) | ((v4m)b & ~m)); } /* m ? a : b */
HV_ALWAYS_INLINE static inline v4d keep(v4m m, v4d a) { return (v4d)((v4m)a & m); }                         /* m ? a : +0 */
HV_ALWAYS_INLINE static inline int any(v4m m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }

/* sqrt lane by lane: one vsqrtpd where math-errno is off (this file). */
HV_ALWAYS_INLINE static inline v4d vsqrt(v4d x) {
  v4d r;
  for (int l = 0; l < LANES; ++l) r[l] = sqrt(x[l]);
  return r;
}

/* hv_hg_sample_cos on four lanes with one g (a uniform grid's); `small`
 * is |g| < 1/3, which picks the form, as there. */
HV_ALWAYS_INLINE static inline v4d hg_sample_cos_one_g(double g, bool small, v4d u) {
  v4d c = small ? HV_HG_COS_SMALL_G(g, u) : HV_HG_COS_LARGE_G(g, u);
  v4d one = splat(1.0);
  return pick(c < -one, -one, pick(c > one, one, c));
}

/* hv_hg_sample_cos on four lanes, each with its g; the form is chosen per
 * lane by |g| < 1/3, as there, and only the forms some lane needs are
 * computed (`need`: the lanes whose result is used). */
HV_ALWAYS_INLINE static inline v4d hg_sample_cos(v4d g, v4d u, v4m need) {
  const v4d one = splat(1.0);
  v4m small = (v4d)((v4u)g & ~(v4u)splat(-0.0)) < splat(1.0 / 3.0); /* |g| < 1/3 */
  v4d c = splat(0.0);
  if (any(need & small)) c = HV_HG_COS_SMALL_G(g, u);
  if (any(need & ~small)) c = pick(small, c, HV_HG_COS_LARGE_G(g, u));
  return pick(c < -one, -one, pick(c > one, one, c));
}

/* hv_dir_from_cos_phi on four lanes (hv_onb, hv_sincos_2pi inlined). */
HV_ALWAYS_INLINE static inline void dir_from_cos_phi(const v4d w[3], v4d cos_theta, v4d turns, v4d out[3]) {
  const v4d one = splat(1.0), zero = splat(0.0);
  const v4m sign_bit = (v4m)splat(-0.0);
  v4d sign = (v4d)(((v4m)w[2] & sign_bit) | (v4m)one); /* copysign(1, w.z) */
  v4d a = -1.0 / (sign + w[2]);
  v4d c = w[0] * w[1] * a;
  v4d t[3] = {1.0 + sign * w[0] * w[0] * a, sign * c, -sign * w[0]};
  v4d b[3] = {c, sign + w[1] * w[1] * a, -w[1]};
  v4d s2 = 1.0 - cos_theta * cos_theta;
  v4d sin_theta = vsqrt(pick(s2 > zero, s2, zero)); /* sqrt(+0) = +0, the scalar's 0 */
  v4d x = 4.0 * turns;
  v4i iq = __builtin_convertvector(x + 0.5, v4i); /* truncation, as (int) */
  v4d f = (x - __builtin_convertvector(iq, v4d)) * 1.57079632679489661923;
  v4d f2 = f * f;
  v4d sp = HV_SIN_POLY(f, f2), cp = HV_COS_POLY(f2);
  v4u q = __builtin_convertvector(iq & 3, v4u);
  v4m odd = (v4m)-(q & 1);
  v4d sphi = (v4d)((v4u)pick(odd, cp, sp) ^ ((q >> 1) << 63)); /* hv_negate_if */
  v4d cphi = (v4d)((v4u)pick(odd, sp, cp) ^ (((q ^ (q >> 1)) & 1) << 63));
  v4d px = sin_theta * cphi, py = sin_theta * sphi;
  for (int i = 0; i < 3; ++i) out[i] = px * t[i] + py * b[i] + cos_theta * w[i];
}

/* What one photon adds to the tally, kept until every earlier photon's is
 * added (hv_trace_photon's order). */
typedef struct record {
  double specular, absorbed, cos_t, eta, w, tau;
  double truncated; /* the weight the scattering bound stopped (> 0), or 0 */
  hv_ray_t ray; /* where it left */
  hetinv_face_t face;
  int32_t scatterings;
  bool entered, exited, finished;
  hv_path_log_t log; /* gradient passes: the photon's score log */
} record_t;

typedef struct lanes {
  /* The photons in flight: position, direction, weight, pathlength and
   * absorbed power, lane by lane; the distance of the flight's (tentative)
   * collision, and the angles its block drew for the scattering there. */
  v4d p[3], d[3], w, tau, absorbed, x, u1, u2;
  v4m scatterings;
  unsigned active; /* bit l: lane l holds a photon */
  uint64_t photon[LANES];
  /* Each photon's voxel (v, k) where the scalar loop's matters: from its
   * launch or reflection; a delta lane's collisions leave it (at_boundary
   * locates the exit again, as hv_ray_march_delta does). */
  hv_ray_t at[LANES];
  hv_rng_t rng[LANES];
  record_t ring[RING]; /* photon n at n % RING */
  uint64_t next, added; /* the next photon to launch, and to add */
} lanes_t;

static void lane_ray(const lanes_t *s, int l, hv_ray_t *r) {
  *r = s->at[l];
  for (int a = 0; a < 3; ++a) {
    r->p[a] = s->p[a][l];
    r->d[a] = s->d[a][l];
  }
}

static void lane_set_ray(lanes_t *s, int l, const hv_ray_t *r) {
  s->at[l] = *r;
  for (int a = 0; a < 3; ++a) {
    s->p[a][l] = r->p[a];
    s->d[a][l] = r->d[a];
  }
}

static void finish(lanes_t *s, int l) {
  record_t *rec = &s->ring[s->photon[l] % RING];
  rec->absorbed = s->absorbed[l];
  rec->finished = true;
  s->active &= ~(1u << l);
}

/* Launches photon s->next into lane l; false if no power entered (its
 * record is then finished and the lane still free). */
static bool launch(const hv_tracer_t *tr, const hv_plan_t *plan, uint64_t seed, uint32_t stream, lanes_t *s,
                   int l) {
  uint64_t n = s->next++;
  record_t *rec = &s->ring[n % RING];
  hv_path_log_t log = rec->log; /* its entries' room is kept */
  *rec = (record_t){.finished = false};
  rec->log = log;
  hv_path_log_reset(&rec->log);
  s->rng[l] = hv_rng_init(seed, plan->key, n, stream);
  hv_ray_t r;
  double w;
  rec->entered = hv_photon_launch(tr, plan, &s->rng[l], &r, &w, &rec->specular);
  if (!rec->entered) {
    rec->finished = true;
    return false;
  }
  s->photon[l] = n;
  lane_set_ray(s, l, &r);
  s->w[l] = w;
  s->tau[l] = 0.0;
  s->absorbed[l] = 0.0;
  s->scatterings[l] = 0;
  s->active |= 1u << l;
  return true;
}

/* Lane l's flight reached the boundary: as the scalar loop, to the box's
 * face (logged whole in a gradient pass), then reflected (the lane flies
 * on) or gone (recorded). */
static void at_boundary(const hv_grid_t *grid, lanes_t *s, int l, bool grad) {
  hv_ray_t r;
  lane_ray(s, l, &r);
  double dist, cos_t, eta, p0[3] = {r.p[0], r.p[1], r.p[2]};
  hetinv_face_t face;
  hv_ray_exit_box(grid, &r, &dist, &face);
  if (grad) hv_path_log_add_ray(&s->ring[s->photon[l] % RING].log, p0, r.d, dist);
  if (grid->delta) hv_ray_locate(grid, &r); /* as hv_ray_march_delta: the last voxel inside */
  double tau = s->tau[l] + dist;
  s->tau[l] = tau;
  bool reflected = hv_photon_reflects(grid, &s->rng[l], &r, face, &cos_t, &eta);
  lane_set_ray(s, l, &r);
  if (reflected) return;
  record_t *rec = &s->ring[s->photon[l] % RING];
  rec->exited = true;
  rec->ray = r;
  rec->face = face;
  rec->cos_t = cos_t;
  rec->eta = eta;
  rec->w = s->w[l];
  rec->tau = tau;
  rec->scatterings = (int32_t)s->scatterings[l];
  finish(s, l);
}

/* Adds the finished photons that no unfinished one precedes. In a
 * gradient pass each photon's log is the tally's path log while its exit
 * scores, then applied if it scored, as hv_trace_photon does. */
static void add_finished(const hv_tracer_t *tr, const hv_plan_t *plan, lanes_t *s, hv_tally_t *tally) {
  for (; s->added < s->next; ++s->added) {
    record_t *rec = &s->ring[s->added % RING];
    if (!rec->finished) return;
    tally->stats[HV_STAT_SPECULAR] += rec->specular;
    if (!rec->entered) continue;
    hv_grad_tally_t *gt = tally->grad;
    if (rec->exited) {
      const hv_exit_t leaving = {&rec->ray, rec->face, rec->cos_t, rec->eta, rec->w, rec->tau, rec->scatterings};
      if (gt) {
        hv_path_log_t own = gt->path;
        gt->path = rec->log;
        hv_photon_exit(tr, plan, &leaving, tally);
        rec->log = gt->path;
        gt->path = own;
      } else {
        hv_photon_exit(tr, plan, &leaving, tally);
      }
    }
    if (rec->truncated > 0.0) {
      tally->stats[HV_STAT_TRUNCATED] += rec->truncated;
      tally->stats[HV_STAT_TRUNCATED_PATHS] += 1.0;
    }
    tally->stats[HV_STAT_ABSORBED] += rec->absorbed;
    if (gt && rec->log.scored) hv_grad_apply_log(gt, tr->grid, &rec->log);
  }
}

bool hv_lanes_fit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_tally_t *tally) {
  return (tally->grad == NULL || tally->grad->jvp.tangents == 0) && (tr->grid->uniform || tr->grid->delta) &&
         plan->vertex_count == 0;
}

/* hv_voxel_inside of the four lanes' q at once (narrow grids: int32
 * strides); a lane not in `in` gets some index in the grid. */
HV_ALWAYS_INLINE static inline v4i voxels_at(const hv_locator_t *loc, v4m in, const v4d q[3]) {
  v4i k = {0, 0, 0, 0};
  for (int a = 0; a < 3; ++a) {
    v4d lo = splat(loc->lo[a]);
    v4i i = __builtin_convertvector((pick(in, q[a], lo) - lo) * splat(loc->inv_h[a]), v4i);
    v4i last = {loc->last[a], loc->last[a], loc->last[a], loc->last[a]};
    i = (v4i)(((v4i)(i <= last) & i) | (~(v4i)(i <= last) & last));
    k += i * (int32_t)loc->stride[a];
  }
  return k;
}

/* Delta tracking's flights, as hv_ray_march_delta runs them, on each
 * lane's stream: a lane in `in` (its first tentative collision q lies in
 * the box) tests collisions until one is kept (returned in the mask, q
 * moved to it, its record's albedo and g read) or the flight leaves the
 * box (set in *out). Rejections are looped here, lane by lane, so that
 * every round scatters every lane still in the box. Only the voxel index
 * is tracked: s->at's voxel matters at the boundary alone, where
 * at_boundary locates it again, as hv_ray_march_delta does. The four
 * lanes' first voxels are located and their loads started first: their
 * cache misses (a large grid's byte and record) overlap. */
HV_ALWAYS_INLINE static inline v4m keep_tentative(const hv_tracer_t *tr, const hv_locator_t *loc, lanes_t *s, v4m in,
                                                 v4d q[3], v4m *out, v4d *albedo, v4d *g) {
  const hv_grid_t *grid = tr->grid;
  v4m kept = in;
  int64_t first[LANES];
  if (loc->narrow) {
    v4i k = voxels_at(loc, in, q);
    for (int l = 0; l < LANES; ++l) first[l] = k[l];
  }
  for (int l = 0; l < LANES; ++l) {
    if (!in[l]) continue;
    if (!loc->narrow) {
      const double c[3] = {q[0][l], q[1][l], q[2][l]};
      first[l] = hv_voxel_inside(loc, c);
    }
    HV_PREFETCH(&grid->sigma_t_q[first[l]]);
    HV_PREFETCH(&grid->voxel[first[l]]);
  }
  for (int l = 0; l < LANES; ++l) {
    if (!in[l]) continue;
    int64_t k = first[l];
    double c[3] = {q[0][l], q[1][l], q[2][l]};
    while (!hv_delta_keep(grid, k, hv_rng_u32(&s->rng[l]))) {
      double x = s->x[l] + hv_exp_sample(tr->exp_table, hv_rng_u64(&s->rng[l]), &s->rng[l]) * grid->inv_majorant;
      s->x[l] = x;
      for (int a = 0; a < 3; ++a) c[a] = s->p[a][l] + x * s->d[a][l];
      if (!hv_grid_contains(grid, c)) {
        kept[l] = 0;
        (*out)[l] = -1;
        break;
      }
      k = hv_voxel_inside(loc, c);
    }
    if (!kept[l]) continue;
    for (int a = 0; a < 3; ++a) q[a][l] = c[a];
    (*albedo)[l] = grid->voxel[k].albedo;
    (*g)[l] = grid->voxel[k].g;
  }
  return kept;
}

/* The loop, inlined four times with `delta` and `grad` constants. Each
 * round draws every lane a flight and ends it: at a collision, or at the
 * box's face. A uniform grid (!delta): every voxel is voxel 0, and a
 * flight's collision is its first tentative one (x = depth/σt). */
HV_ALWAYS_INLINE static inline void trace_lanes(const hv_tracer_t *tr, const hv_plan_t *plan, uint64_t seed,
                                                uint32_t stream, uint64_t first, uint64_t end, hv_tally_t *tally,
                                                const bool delta, const bool grad) {
  const hv_grid_t *grid = tr->grid;
  const double step = delta ? grid->inv_majorant : grid->inv_sigma_t;
  const bool small_g = fabs(grid->voxel[0].g) < 1.0 / 3.0; /* grids of one g only */
  const v4d zero = splat(0.0);
  v4d albedo = splat(grid->voxel[0].albedo), g = splat(grid->voxel[0].g);
  const hv_locator_t loc = hv_locator_of(grid);
  lanes_t s;
  s.active = 0;
  s.next = s.added = first;
  for (int i = 0; i < RING; ++i) s.ring[i].log = grad ? tally->grad->lane_logs[i] : (hv_path_log_t){0};
  for (;;) {
    for (int l = 0; l < LANES; ++l) {
      while (!(s.active >> l & 1u) && s.next < end && s.next - s.added < RING) {
        if (!launch(tr, plan, seed, stream, &s, l)) add_finished(tr, plan, &s, tally);
      }
    }
    if (s.active == 0) break;
    /* A lane without a flight draws one: one Philox block per flight and
     * scattering, as in the scalar loop. */
    v4m act;
    for (int l = 0; l < LANES; ++l) {
      act[l] = -(int64_t)(s.active >> l & 1u);
      if (!act[l]) continue;
      philox4x32_ctr_t blk = hv_rng_block(&s.rng[l]);
      s.x[l] = hv_exp_sample(tr->exp_table, (uint64_t)blk.v[0] << 32 | blk.v[1], &s.rng[l]) * step;
      s.u1[l] = hv_unit_from_u32(blk.v[2]);
      s.u2[l] = hv_unit_from_u32(blk.v[3]);
    }
    /* The (tentative) collision, if it lies in the box. */
    v4d q[3];
    v4m in = act;
    for (int a = 0; a < 3; ++a) {
      q[a] = s.p[a] + s.x * s.d[a];
      in &= (q[a] >= splat(grid->lo[a])) & (q[a] <= splat(grid->hi[a]));
    }
    v4m out = act & ~in;
    v4m hit = delta ? keep_tentative(tr, &loc, &s, in, q, &out, &albedo, &g) : in;
    if (any(out)) {
      for (int l = 0; l < LANES; ++l) {
        if (out[l]) at_boundary(grid, &s, l, grad);
      }
    }
    if (grad && any(hit)) { /* the flight, whole: split into voxels if the path scores */
      for (int l = 0; l < LANES; ++l) {
        if (!hit[l]) continue;
        const double p0[3] = {s.p[0][l], s.p[1][l], s.p[2][l]}, d[3] = {s.d[0][l], s.d[1][l], s.d[2][l]};
        hv_path_log_add_ray(&s.ring[s.photon[l] % RING].log, p0, d, s.x[l]);
      }
    }
    for (int a = 0; a < 3; ++a) s.p[a] = pick(hit, q[a], s.p[a]);
    s.tau = s.tau + keep(hit, s.x); /* tau + 0 is tau */
    /* A collision: the albedo, then the phase function. */
    s.scatterings -= hit;
    s.absorbed = s.absorbed + keep(hit, s.w * (1.0 - albedo));
    s.w = pick(hit, s.w * albedo, s.w);
    v4m live = hit & (s.w > zero), ended = hit & ~live, truncated = {0, 0, 0, 0};
    if (tr->max_scattering > 0) {
      truncated = live & (s.scatterings > (int64_t)tr->max_scattering);
      live &= ~truncated;
    }
    if (any(live)) {
      v4d d_new[3];
      v4d cos_theta = delta && !grid->uniform_g ? hg_sample_cos(g, s.u1, live)
                                                : hg_sample_cos_one_g(grid->voxel[0].g, small_g, s.u1);
      dir_from_cos_phi(s.d, cos_theta, s.u2, d_new);
      for (int a = 0; a < 3; ++a) s.d[a] = pick(live, d_new[a], s.d[a]);
      for (int l = 0; grad && l < LANES; ++l) { /* the vertex's σs and phase scores */
        if (!live[l]) continue;
        hv_path_log_set_ray_vertex(&s.ring[s.photon[l] % RING].log, cos_theta[l]);
      }
    }
    v4m low = live & (s.w < splat(tr->roulette_weight));
    if (any(ended | truncated | low)) {
      for (int l = 0; l < LANES; ++l) {
        if (ended[l]) {
          finish(&s, l); /* a purely absorbing voxel */
        } else if (truncated[l]) {
          record_t *rec = &s.ring[s.photon[l] % RING];
          rec->truncated = s.w[l]; /* > 0: the lane was live */
          finish(&s, l);
        } else if (low[l]) {
          if (hv_rng_uniform(&s.rng[l]) >= tr->roulette_survival) {
            finish(&s, l);
          } else {
            s.w[l] /= tr->roulette_survival;
          }
        }
      }
    }
    add_finished(tr, plan, &s, tally);
  }
  add_finished(tr, plan, &s, tally);
  for (int i = 0; grad && i < RING; ++i) {
    if (s.ring[i].log.out_of_memory) tally->grad->path.out_of_memory = true; /* reported after the pass */
    s.ring[i].log.out_of_memory = false;
    tally->grad->lane_logs[i] = s.ring[i].log; /* its room, for the next batch */
  }
}

/* The tally's ring of score logs, made on its first lanes pass: each log
 * then keeps the room its longest path needed, so that later batches
 * allocate and clear none (64 logs of 256 entries or more: clearing them in
 * every batch cost about 4 % of A1's gradient pass, page faults included). */
static bool take_lane_logs(hv_grad_tally_t *gt) {
  if (gt->lane_logs != NULL) return true;
  gt->lane_logs = hv_calloc(gt->path.ctx, RING, sizeof *gt->lane_logs);
  if (gt->lane_logs == NULL) return false;
  for (int i = 0; i < RING; ++i) gt->lane_logs[i] = (hv_path_log_t){.ctx = gt->path.ctx};
  return true;
}

void hv_grad_tally_release_logs(hv_grad_tally_t *gt) {
  for (int i = 0; gt->lane_logs && i < RING; ++i) hv_path_log_release(&gt->lane_logs[i]);
  hv_free(gt->path.ctx, gt->lane_logs);
  gt->lane_logs = NULL;
  hv_path_log_release(&gt->path);
  hv_path_log_release(&gt->chain);
}

HV_TARGET_CLONES_X86_64_V3
void hv_trace_lanes(const hv_tracer_t *tr, const hv_plan_t *plan, uint64_t seed, uint32_t stream,
                    uint64_t first, uint64_t end, hv_tally_t *tally) {
  bool uniform = tr->grid->uniform, grad = tally->grad != NULL;
  if (grad && !take_lane_logs(tally->grad)) {
    tally->grad->path.out_of_memory = true; /* reported after the pass */
    return;
  }
  if (uniform && !grad) trace_lanes(tr, plan, seed, stream, first, end, tally, false, false);
  if (!uniform && !grad) trace_lanes(tr, plan, seed, stream, first, end, tally, true, false);
  if (uniform && grad) trace_lanes(tr, plan, seed, stream, first, end, tally, false, true);
  if (!uniform && grad) trace_lanes(tr, plan, seed, stream, first, end, tally, true, true);
}
