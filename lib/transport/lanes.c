#include "transport/lanes.h"

#include <math.h>
#include <string.h>

#include "core/bits.h"
#include "core/compiler.h"
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

static inline v4d splat(double x) { return (v4d){x, x, x, x}; }
static inline v4d pick(v4m m, v4d a, v4d b) { return (v4d)(((v4m)a & m) | ((v4m)b & ~m)); } /* m ? a : b */
static inline v4d keep(v4m m, v4d a) { return (v4d)((v4m)a & m); }                         /* m ? a : +0 */
static inline int any(v4m m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }

/* sqrt lane by lane: one vsqrtpd where math-errno is off (this file). */
HV_ALWAYS_INLINE static inline v4d vsqrt(v4d x) {
  v4d r;
  for (int l = 0; l < LANES; ++l) r[l] = sqrt(x[l]);
  return r;
}

/* hv_hg_sample_cos on four lanes with one g (the grid's); `small` is
 * |g| < 1/3, which picks the form, as there. */
HV_ALWAYS_INLINE static inline v4d hg_sample_cos(double g, bool small, v4d u) {
  v4d c;
  if (small) {
    v4d a = 1.0 - 2.0 * u, d = 1.0 - g * a;
    c = (-2.0 * a + g * (a * a + 3.0 - g * (2.0 * a - g * (a * a - 1.0)))) / (2.0 * d * d);
  } else {
    double A = (1.0 - g) * (1.0 + g);
    v4d D = 1.0 - g + 2.0 * g * u, D2 = D * D;
    c = ((1.0 + g * g) * D2 - A * A) / (2.0 * g * D2);
  }
  v4d one = splat(1.0);
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
  v4d sp = f + f * f2 * (-1.0 / 6 + f2 * (1.0 / 120 + f2 * (-1.0 / 5040 + f2 * (1.0 / 362880 +
           f2 * (-1.0 / 39916800 + f2 * (1.0 / 6227020800 + f2 * (-1.0 / 1307674368000)))))));
  v4d cp = 1.0 + f2 * (-0.5 + f2 * (1.0 / 24 + f2 * (-1.0 / 720 + f2 * (1.0 / 40320 +
           f2 * (-1.0 / 3628800 + f2 * (1.0 / 479001600 + f2 * (-1.0 / 87178291200 +
           f2 * (1.0 / 20922789888000))))))));
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
  double specular, absorbed, cos_t, eta, w, tau, truncated;
  hv_ray_t ray; /* where it left */
  hetinv_face_t face;
  int32_t scatterings;
  bool entered, exited, was_truncated, finished;
} record_t;

typedef struct lanes {
  /* The photons in flight: position, direction, weight, pathlength and
   * absorbed power, lane by lane. */
  v4d p[3], d[3], w, tau, absorbed;
  v4m scatterings;
  unsigned active; /* bit l: lane l holds a photon */
  uint64_t photon[LANES];
  hv_ray_t at[LANES]; /* each photon's voxel (v, k) as the scalar loop keeps it */
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
  *rec = (record_t){.finished = false};
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
 * face, then reflected (the lane flies on) or gone (recorded). */
static void at_boundary(const hv_grid_t *grid, lanes_t *s, int l) {
  hv_ray_t r;
  lane_ray(s, l, &r);
  double dist, cos_t, eta;
  hetinv_face_t face;
  hv_ray_exit_box(grid, &r, &dist, &face);
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

/* Adds the finished photons that no unfinished one precedes. */
static void add_finished(const hv_tracer_t *tr, const hv_plan_t *plan, lanes_t *s, hv_tally_t *tally) {
  for (; s->added < s->next; ++s->added) {
    const record_t *rec = &s->ring[s->added % RING];
    if (!rec->finished) return;
    tally->stats[HV_STAT_SPECULAR] += rec->specular;
    if (!rec->entered) continue;
    if (rec->exited) {
      const hv_exit_t leaving = {&rec->ray, rec->face, rec->cos_t, rec->eta, rec->w, rec->tau, rec->scatterings};
      hv_photon_exit(tr, plan, &leaving, tally);
    }
    if (rec->was_truncated) {
      tally->stats[HV_STAT_TRUNCATED] += rec->truncated;
      tally->stats[HV_STAT_TRUNCATED_PATHS] += 1.0;
    }
    tally->stats[HV_STAT_ABSORBED] += rec->absorbed;
  }
}

bool hv_lanes_fit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_tally_t *tally) {
  return tally->grad == NULL && tr->grid->uniform && plan->vertex_count == 0;
}

HV_TARGET_CLONES_X86_64_V3
void hv_trace_lanes(const hv_tracer_t *tr, const hv_plan_t *plan, uint64_t seed, uint32_t stream,
                    uint64_t first, uint64_t end, hv_tally_t *tally) {
  const hv_grid_t *grid = tr->grid;
  const hv_voxel_t *vx = &grid->voxel[0]; /* every voxel is alike */
  const double albedo = vx->albedo, g = vx->g, inv_sigma_t = grid->inv_sigma_t;
  const bool small_g = fabs(g) < 1.0 / 3.0;
  const v4d zero = splat(0.0);
  lanes_t s;
  s.active = 0;
  s.next = s.added = first;
  for (;;) {
    for (int l = 0; l < LANES; ++l) {
      while (!(s.active >> l & 1u) && s.next < end && s.next - s.added < RING) {
        if (!launch(tr, plan, seed, stream, &s, l)) add_finished(tr, plan, &s, tally);
      }
    }
    if (s.active == 0) break;
    /* One Philox block per flight and scattering, as in the scalar loop. */
    v4d depth = zero, u1 = splat(0.5), u2 = splat(0.5);
    v4m act;
    for (int l = 0; l < LANES; ++l) {
      act[l] = -(int64_t)(s.active >> l & 1u);
      if (!act[l]) continue;
      philox4x32_ctr_t blk = hv_rng_block(&s.rng[l]);
      depth[l] = hv_exp_sample(tr->exp_table, (uint64_t)blk.v[0] << 32 | blk.v[1], &s.rng[l]);
      u1[l] = hv_unit_from_u32(blk.v[2]);
      u2[l] = hv_unit_from_u32(blk.v[3]);
    }
    /* hv_ray_march_uniform: the collision, if it lies in the box. */
    v4d x = depth * inv_sigma_t, q[3];
    v4m in = act;
    for (int a = 0; a < 3; ++a) {
      q[a] = s.p[a] + x * s.d[a];
      in &= (q[a] >= splat(grid->lo[a])) & (q[a] <= splat(grid->hi[a]));
    }
    for (int a = 0; a < 3; ++a) s.p[a] = pick(in, q[a], s.p[a]);
    s.tau = s.tau + keep(in, x); /* tau + 0 is tau */
    v4m out = act & ~in;
    if (any(out)) {
      for (int l = 0; l < LANES; ++l) {
        if (out[l]) at_boundary(grid, &s, l);
      }
    }
    /* A collision: the albedo, then the phase function. */
    s.scatterings -= in;
    s.absorbed = s.absorbed + keep(in, s.w * (1.0 - albedo));
    s.w = pick(in, s.w * albedo, s.w);
    v4m live = in & (s.w > zero), ended = in & ~live, truncated = {0, 0, 0, 0};
    if (tr->max_scattering > 0) {
      truncated = live & (s.scatterings > (int64_t)tr->max_scattering);
      live &= ~truncated;
    }
    v4d d_new[3];
    dir_from_cos_phi(s.d, hg_sample_cos(g, small_g, u1), u2, d_new);
    for (int a = 0; a < 3; ++a) s.d[a] = pick(live, d_new[a], s.d[a]);
    v4m low = live & (s.w < splat(tr->roulette_weight));
    if (any(ended | truncated | low)) {
      for (int l = 0; l < LANES; ++l) {
        if (ended[l]) {
          finish(&s, l); /* a purely absorbing medium */
        } else if (truncated[l]) {
          record_t *rec = &s.ring[s.photon[l] % RING];
          rec->was_truncated = true;
          rec->truncated = s.w[l];
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
}
