#include "transport/tracer.h"

#include <math.h>
#include <string.h>

#include "core/compiler.h"
#include "medium/phase.h"
#include "transport/delta.h"
#include "transport/photon.h"
#include "transport/walk.h"

typedef struct extinction_visit {
  hv_grad_tally_t *gt;
  double w;
} extinction_visit_t;

HV_ALWAYS_INLINE static inline void add_extinction_visit(void *user, int64_t k, double seg) {
  const extinction_visit_t *x = user;
  hv_grad_add_extinction(x->gt, k, -seg * x->w);
}

/* Compiled for x86-64-v3 too, like the photon loop that calls it: each
 * log's first ray is located, and the baseline's floor is a branchy
 * emulation. */
HV_TARGET_CLONES_X86_64_V3
void hv_grad_apply_log(hv_grad_tally_t *gt, const hv_grid_t *grid, const hv_path_log_t *log) {
  hv_ray_t end = {.k = -1}; /* where the last ray split ended: the vertex */
  for (size_t i = 0; i < log->count; ++i) {
    const hv_log_entry_t *e = &log->entries[i];
    double w = log->cum - e->cum;
    if (e->kind == HV_LOG_RAY) {
      if (w == 0.0) {
        end.k = -1;
        continue;
      }
      /* -length·w to σa and σs of every voxel the ray crosses. */
      extinction_visit_t x = {gt, w};
      hv_walk_log_ray(grid, e, &end, add_extinction_visit, &x);
      if (e->u.ray.scatter) hv_grad_add(gt, HETINV_PARAM_SIGMA_S, end.k, (1.0 / grid->sigma_s[end.k]) * w);
      if (e->u.ray.phase) hv_grad_add(gt, HETINV_PARAM_G, end.k, hv_log_phase_score(grid, end.k, e->u.ray.cos_theta) * w);
      continue;
    }
    if (w == 0.0) continue;
    int64_t k = e->u.at.voxel;
    if (k < 0) k = end.k; /* the vertex that ended the last ray */
    if (k < 0) {
      hv_ray_t r = {.p = {e->u.at.p[0], e->u.at.p[1], e->u.at.p[2]}, .d = {0.0, 0.0, 0.0}};
      hv_ray_locate(grid, &r);
      k = r.k;
    }
    switch (e->kind) {
      case HV_LOG_SEGMENT: hv_grad_add_extinction(gt, k, -e->u.at.value * w); break;
      case HV_LOG_SCATTER: hv_grad_add(gt, HETINV_PARAM_SIGMA_S, k, hv_log_vertex_score(grid, e, k) * w); break;
      case HV_LOG_PHASE: hv_grad_add(gt, HETINV_PARAM_G, k, hv_log_vertex_score(grid, e, k) * w); break;
      case HV_LOG_RAY: break;
    }
  }
}

/* Whether p lies in [lo, hi] (a sensor's reach, plan.h): bitwise ANDs,
 * no early exits, since most vertices fail on the section's one axis. */
HV_ALWAYS_INLINE static inline bool in_box(const double p[3], const double lo[3], const double hi[3]) {
  return (p[0] >= lo[0]) & (p[0] <= hi[0]) & (p[1] >= lo[1]) & (p[1] <= hi[1]) & (p[2] >= lo[2]) & (p[2] <= hi[2]);
}

/* A photon that reaches the boundary from inside: returns 1 if it leaves
 * (and scores it), 0 if it is reflected back (r->d updated). */
static int cross_boundary(const hv_tracer_t *tr, const hv_plan_t *plan, hv_rng_t *rng,
                          hv_ray_t *r, hetinv_face_t face, double w, double tau, int32_t scatterings,
                          hv_tally_t *tally) {
  double cos_t, eta;
  if (hv_photon_reflects(tr->grid, rng, r, face, &cos_t, &eta)) return 0;
  const hv_exit_t leaving = {r, face, cos_t, eta, w, tau, scatterings};
  hv_photon_exit(tr, plan, &leaving, tally);
  return 1;
}

/* The photon loop proper; hv_trace_photon wraps it with the score log.
 * It is inlined twice, with grad a constant: the forward pass's free
 * flights then carry no test for a log at each voxel crossing. */
HV_ALWAYS_INLINE static inline void trace(const hv_tracer_t *tr, const hv_plan_t *plan,
                                          hv_rng_t *rng, hv_tally_t *tally, const bool grad) {
  const hv_grid_t *grid = tr->grid;
  hv_path_log_t *plog = grad ? &tally->grad->path : NULL;
  hv_ray_t r;
  double w, specular;
  bool entered = hv_photon_launch(tr, plan, rng, &r, &w, &specular);
  tally->stats[HV_STAT_SPECULAR] += specular;
  if (!entered) return;

  /* A score pass pays twice for a delta-tracked path that reaches a
   * sensor: its tentative collisions, then the walk that splits its
   * flights into voxels. Where the plan has a vertex sensor (next-event
   * connections), nearly every path does, and stepping once is cheaper
   * (the built-in Fig. 4 scene's gradient pass: 6 % faster stepped); with
   * exit sensors only, fewer do (A1-het's Rd: 77 %, 5 % faster by delta). */
  const bool delta = grid->delta && (!grad || plan->vertex_count == 0);
  /* A logged flight (uniform or delta) that ends at a vertex: with no
   * vertex sensor nothing splats between the vertex and its scattering, so
   * the flight's entry carries the vertex's phase score too. */
  const bool vertex_in_ray = plog && (grid->uniform || delta) && plan->vertex_count == 0;
  double tau = 0.0, absorbed = 0.0;
  int32_t scatterings = 0;
  for (;;) {
    double dist;
    hetinv_face_t face;
    /* One Philox block per flight and scattering: 64 bits for the free path,
     * 32 + 32 for the angles. Rare draws (Fresnel, roulette) come from the
     * stream's buffered outputs, whose counters are never these. */
    philox4x32_ctr_t blk = hv_rng_block(rng);
    double depth = hv_exp_sample(tr->exp_table, (uint64_t)blk.v[0] << 32 | blk.v[1], rng);
    int collided;
    if (delta) {
      /* Delta tracking draws the collision from regular tracking's law, and
       * the score is that law's (per-voxel segments, walk.h): the score
       * pass logs the flight whole, as a uniform grid's, and splits it into
       * voxels only if a splat follows it (hv_grad_apply_log). */
      double p0[3] = {r.p[0], r.p[1], r.p[2]};
      collided = hv_ray_march_delta(grid, &r, depth, tr->exp_table, rng, &dist, &face);
      if (plog) hv_path_log_add_ray(plog, p0, r.d, dist);
    } else {
      collided = hv_ray_march(grid, &r, depth, &dist, &face, plog);
    }
    tau += dist;
    if (!collided) {
      if (cross_boundary(tr, plan, rng, &r, face, w, tau, scatterings, tally)) break;
      continue;
    }
    ++scatterings;
    const hv_voxel_t *vx = &grid->voxel[r.k];
    double albedo = vx->albedo;
    absorbed += w * (1.0 - albedo);
    w *= albedo;
    if (!(w > 0.0)) break; /* a purely absorbing voxel */
    if (tr->max_scattering > 0 && scatterings > tr->max_scattering) {
      tally->stats[HV_STAT_TRUNCATED] += w;
      tally->stats[HV_STAT_TRUNCATED_PATHS] += 1.0;
      break;
    }
    if (plog && !vertex_in_ray) {
      if (grid->uniform || delta) {
        hv_path_log_set_ray_scatter(plog);
      } else {
        hv_path_log_add(plog, HV_LOG_SCATTER, r.k, 0.0);
      }
    }
    hv_phase_t phase = {HV_PHASE_HG, vx->g};
    if (scatterings >= tr->min_scattering && in_box(r.p, plan->reach_lo, plan->reach_hi)) {
      for (int32_t i = 0; i < plan->vertex_count; ++i) {
        const hv_sensor_target_t *t = plan->at_vertex[i];
        if (in_box(r.p, t->reach_lo, t->reach_hi)) t->kind->at_vertex(tr, plan, t, &r, w, phase, tau, rng, tally);
      }
    }
    double d_new[3];
    double cos_theta = hv_phase_sample(phase, r.d, hv_unit_from_u32(blk.v[2]),
                                       hv_unit_from_u32(blk.v[3]), d_new);
    if (vertex_in_ray) {
      hv_path_log_set_ray_vertex(plog, cos_theta);
    } else if (plog) {
      if (grid->uniform) {
        hv_path_log_add_at(plog, HV_LOG_PHASE, r.p, cos_theta); /* voxel found when applied */
      } else {
        hv_path_log_add(plog, HV_LOG_PHASE, r.k, cos_theta);
      }
    }
    memcpy(r.d, d_new, sizeof r.d);
    if (w < tr->roulette_weight) {
      if (hv_rng_uniform(rng) >= tr->roulette_survival) break;
      w /= tr->roulette_survival;
    }
  }
  tally->stats[HV_STAT_ABSORBED] += absorbed;
}

HV_TARGET_CLONES_X86_64_V3
void hv_trace_photon(const hv_tracer_t *tr, const hv_plan_t *plan, hv_rng_t *rng, hv_tally_t *tally) {
  hv_grad_tally_t *gt = tally->grad;
  if (gt) {
    bool tangent = gt->jvp.tangents > 0;
    hv_path_log_reset(&gt->path);
    if (tangent) hv_jvp_path_begin(&gt->jvp);
    trace(tr, plan, rng, tally, true);
    /* Most paths never reach a sensor: every entry's share is then 0. */
    if (!tangent && gt->path.scored) hv_grad_apply_log(gt, tr->grid, &gt->path);
  } else {
    trace(tr, plan, rng, tally, false);
  }
}
