#include "transport/tracer.h"

#include <math.h>
#include <string.h>

#include "core/compiler.h"
#include "medium/fresnel.h"
#include "medium/phase.h"
#include "sampling/emitter_internal.h"
#include "sampling/pathlength_internal.h"
#include "sampling/sensor_internal.h"

/* A specular chain of a connection stops when its remaining throughput
 * falls below this fraction of its start: the truncation is far below any
 * Monte Carlo error bar. Every hit on a face of the sensor's axis loses at
 * least 1 - R > 0 (no valid sensor direction is totally reflected there),
 * so chains end; total internal reflections at side faces cost nothing and
 * may be many in a narrow box. The bounce limit only guards against a
 * pathological R ≈ 1 and is far beyond any real chain. */
#define HV_CHAIN_CUTOFF 1e-7
#define HV_CHAIN_MAX_BOUNCES 1000000

/* -length·w to σa and σs of every voxel the straight segment crosses;
 * returns the voxel where it ends. */
static int64_t add_ray(hv_grad_tally_t *gt, const hv_grid_t *grid, const double p[3],
                       const double d[3], double length, double w) {
  hv_ray_t r;
  memcpy(r.p, p, sizeof r.p);
  memcpy(r.d, d, sizeof r.d);
  hv_ray_locate(grid, &r);
  hv_dda_t s;
  hv_dda_init(grid, &r, &s);
  hetinv_face_t face;
  for (double t = 0.0; t < length;) {
    int a = hv_dda_axis(&s);
    double end = s.t_next[a] < length ? s.t_next[a] : length;
    hv_grad_add_extinction(gt, r.k, -(end - t) * w);
    t = end;
    if (t >= length || !hv_dda_advance(grid, &r, &s, a, t, &face)) break;
  }
  return r.k;
}

void hv_grad_apply_log(hv_grad_tally_t *gt, const hv_grid_t *grid, const hv_path_log_t *log) {
  int64_t vertex = -1; /* voxel at the end of the last ray split, if known */
  for (size_t i = 0; i < log->count; ++i) {
    const hv_log_entry_t *e = &log->entries[i];
    double w = log->cum - e->cum;
    if (e->kind == HV_LOG_RAY) {
      vertex = -1;
      if (w == 0.0) continue;
      vertex = add_ray(gt, grid, e->u.ray.p, e->u.ray.d, e->u.ray.length, w);
      if (e->u.ray.scatter != 0.0) hv_grad_add(gt, HETINV_PARAM_SIGMA_S, vertex, e->u.ray.scatter * w);
      continue;
    }
    if (w == 0.0) continue;
    int64_t k = e->u.at.voxel;
    if (k < 0) k = vertex; /* the vertex that ended the last ray */
    if (k < 0) {
      hv_ray_t r = {.p = {e->u.at.p[0], e->u.at.p[1], e->u.at.p[2]}, .d = {0.0, 0.0, 0.0}};
      hv_ray_locate(grid, &r);
      k = r.k;
    }
    switch (e->kind) {
      case HV_LOG_SEGMENT: hv_grad_add_extinction(gt, k, -e->u.at.value * w); break;
      case HV_LOG_SCATTER: hv_grad_add(gt, HETINV_PARAM_SIGMA_S, k, e->u.at.value * w); break;
      case HV_LOG_PHASE: hv_grad_add(gt, HETINV_PARAM_G, k, e->u.at.value * w); break;
      case HV_LOG_RAY: break;
    }
  }
}

/* Scores contribution `value` at pathlength tau into pixel `pixel` of every
 * row of target t: added to dst (forward), or, in gradient mode, weighed by
 * the cotangent and added to the splat total of `log`. */
static void score(const hv_plan_t *plan, const hv_sensor_target_t *t, hv_tally_t *tally,
                  double *dst, hv_path_log_t *log, int32_t pixel, double tau, double value) {
  value *= plan->emitter->power;
  hv_grad_tally_t *gt = tally->grad;
  for (int32_t i = 0; i < t->row_count; ++i) {
    const hv_row_target_t *row = &plan->rows[t->first_row + i];
    if (gt && gt->jvp.tangents > 0) {
      size_t T = (size_t)gt->jvp.tangents;
      hv_jvp_splat(&gt->jvp, &gt->path, log == &gt->chain ? log : NULL, row->pathlength, tau, value,
                   dst + ((size_t)row->offset + (size_t)pixel) * T, (size_t)row->pixels * T);
    } else if (gt) {
      log->scored = true;
      log->cum += value * hv_pathlength_dot(row->pathlength, tau,
                                            tally->grad->cotangent + row->offset + pixel, row->pixels);
    } else {
      hv_pathlength_splat(row->pathlength, tau, value, dst + row->offset + pixel, row->pixels);
    }
  }
}

/* Next-event connection from scattering vertex r (direction of arrival
 * d_in, weight w after the albedo, the vertex's phase function, pathlength
 * tau so far) to the orthographic sensor of target t. The light leaves along the sensor's
 * interior direction ω_i, possibly after specular reflections at other
 * faces (or at the sensor's face itself): each chain starts along a sign
 * flip of ω_i and ends when it reaches the sensor face travelling along
 * ω_i; every chain is followed until its throughput is negligible. */
static void connect_sensor(const hv_tracer_t *tr, const hv_plan_t *plan,
                           const hv_sensor_target_t *t, const hv_ray_t *vertex,
                           const double d_in[3], double w, hv_phase_t phase, double tau,
                           hv_tally_t *tally) {
  const hetinv_sensor_t *s = t->sensor;
  const hv_grid_t *grid = tr->grid;
  hv_grad_tally_t *gt = tally->grad;
  hv_path_log_t *chain = gt ? &gt->chain : NULL;
  bool matched = grid->eta == grid->eta_out; /* no reflections: the direct chain only */
  for (int flips = 0; flips < 8; ++flips) {
    if (matched && flips != 0) break;
    double w0[3];
    bool redundant = false;
    for (int a = 0; a < 3; ++a) {
      bool flip = (flips >> a) & 1;
      if (flip && s->dir_in[a] == 0.0) redundant = true; /* same direction as another pattern */
      w0[a] = flip ? -s->dir_in[a] : s->dir_in[a];
    }
    if (redundant) continue;
    double cos_theta = d_in[0] * w0[0] + d_in[1] * w0[1] + d_in[2] * w0[2];
    double start = w * hv_phase_eval(phase, cos_theta);
    if (!(start > 0.0)) continue;
    if (chain) hv_path_log_reset(chain);
    if (gt && gt->jvp.tangents > 0) {
      hv_jvp_chain_begin(&gt->jvp, hv_vertex_voxel(grid, vertex), hv_phase_dlog_dg(phase, cos_theta));
    }
    hv_ray_t r = *vertex;
    memcpy(r.d, w0, sizeof r.d);
    hv_ray_locate(grid, &r);
    double throughput = start, length = 0.0;
    int state = flips;
    for (int bounce = 0; bounce <= HV_CHAIN_MAX_BOUNCES; ++bounce) {
      double dist;
      hetinv_face_t face;
      double depth = hv_ray_to_boundary(grid, &r, &dist, &face, chain);
      throughput *= exp(-depth);
      length += dist;
      int a = hv_face_axis(face);
      if (state == 0 && face == s->face) {
        int32_t pixel = hv_sensor_pixel_at(s, r.p);
        if (pixel >= 0) {
          score(plan, t, tally, tally->values, chain, pixel, tau + length,
                throughput * s->connection_scale);
        }
      }
      /* What the face reflects travels on, flipped along its axis. */
      throughput *= t->reflectance[a];
      if (throughput < HV_CHAIN_CUTOFF * start) break;
      r.d[a] = -r.d[a];
      state ^= 1 << a;
      hv_ray_locate(grid, &r);
    }
    if (chain && chain->cum != 0.0) {
      /* The chain's own segments and the vertex's phase toward w0 score only
       * this chain's splats; its total joins the path's splats. */
      hv_grad_apply_log(gt, grid, chain);
      hv_grad_add(gt, HETINV_PARAM_G, hv_vertex_voxel(grid, vertex),
                  hv_phase_dlog_dg(phase, cos_theta) * chain->cum);
      gt->path.cum += chain->cum;
      gt->path.scored = true;
    }
  }
}

/* A photon that reaches the boundary from inside: returns 1 if it leaves
 * (and scores it), 0 if it is reflected back (r->d updated). */
static int cross_boundary(const hv_tracer_t *tr, const hv_plan_t *plan, hv_rng_t *rng,
                          hv_ray_t *r, hetinv_face_t face, double w, double tau, int32_t scatterings,
                          hv_tally_t *tally) {
  const hv_grid_t *grid = tr->grid;
  int a = hv_face_axis(face);
  double cos_i = fabs(r->d[a]), cos_t;
  double eta = grid->eta_out / grid->eta;
  double R = hv_fresnel_dielectric(cos_i, eta, &cos_t);
  if (R > 0.0 && (R >= 1.0 || hv_rng_uniform(rng) < R)) {
    r->d[a] = -r->d[a];
    hv_ray_locate(grid, r);
    return 0;
  }
  tally->stats[HV_STAT_ESCAPED + face] += w;
  bool counted = scatterings >= tr->min_scattering &&
                 (tr->max_scattering == 0 || scatterings <= tr->max_scattering);
  if (!counted) return 1;
  hv_path_log_t *log = tally->grad ? &tally->grad->path : NULL;
  for (int32_t i = 0; i < plan->hemi_count; ++i) {
    const hv_sensor_target_t *t = &plan->hemi[i];
    if (t->sensor->face != face || hv_sensor_pixel_at(t->sensor, r->p) < 0) continue;
    score(plan, t, tally, tally->values, log, 0, tau, w);
    if (scatterings == 0 && tally->ballistic) score(plan, t, tally, tally->ballistic, log, 0, tau, w);
  }
  if (scatterings == 0 && tally->ballistic && plan->ortho_count > 0) {
    /* Unscattered light is a Dirac in direction: it reaches an orthographic
     * sensor only if it leaves exactly along the sensor's direction. It is
     * reported apart from the values, and has no gradient. */
    double n[3], out[3];
    hv_face_normal(face, n);
    hv_refract_cos(r->d, n, eta, cos_t, out);
    for (int32_t i = 0; i < plan->ortho_count; ++i) {
      const hv_sensor_target_t *t = &plan->ortho[i];
      const double *so = t->sensor->dir_out;
      double c = out[0] * so[0] + out[1] * so[1] + out[2] * so[2];
      if (t->sensor->face != face || c < 1.0 - 1e-12) continue;
      int32_t pixel = hv_sensor_pixel_at(t->sensor, r->p);
      if (pixel >= 0) score(plan, t, tally, tally->ballistic, log, pixel, tau, w * t->sensor->ballistic_scale);
    }
  }
  return 1;
}

/* The photon loop proper; hv_trace_photon wraps it with the score log.
 * It is inlined twice, with grad a constant: the forward pass's free
 * flights then carry no test for a log at each voxel crossing. */
HV_ALWAYS_INLINE static inline void trace(const hv_tracer_t *tr, const hv_plan_t *plan,
                                          hv_rng_t *rng, hv_tally_t *tally, const bool grad) {
  const hv_grid_t *grid = tr->grid;
  hv_path_log_t *plog = grad ? &tally->grad->path : NULL;
  hv_launch_t launch;
  hv_emitter_sample(plan->emitter, rng, &launch);

  /* Refraction into the medium; what the first surface reflects never enters. */
  double n[3], cos_t;
  hv_face_normal(launch.face, n);
  double eta_in = grid->eta / grid->eta_out;
  double R = hv_fresnel_dielectric(fabs(launch.direction[hv_face_axis(launch.face)]), eta_in, &cos_t);
  tally->stats[HV_STAT_SPECULAR] += launch.weight * R;
  double w = launch.weight * (1.0 - R);
  if (!(w > 0.0)) return;
  hv_ray_t r;
  memcpy(r.p, launch.point, sizeof r.p);
  hv_refract_cos(launch.direction, n, eta_in, cos_t, r.d);
  hv_ray_locate(grid, &r);

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
    int collided = hv_ray_march(grid, &r, depth, &dist, &face, plog);
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
    if (plog) {
      if (grid->uniform) {
        hv_path_log_set_ray_scatter(plog, 1.0 / grid->sigma_s[r.k]); /* the flight just logged */
      } else {
        hv_path_log_add(plog, HV_LOG_SCATTER, r.k, 1.0 / grid->sigma_s[r.k]);
      }
    }
    hv_phase_t phase = {HV_PHASE_HG, vx->g};
    if (scatterings >= tr->min_scattering) {
      for (int32_t i = 0; i < plan->ortho_count; ++i) {
        connect_sensor(tr, plan, &plan->ortho[i], &r, r.d, w, phase, tau, tally);
      }
    }
    double d_new[3];
    double cos_theta = hv_phase_sample(phase, r.d, hv_unit_from_u32(blk.v[2]),
                                       hv_unit_from_u32(blk.v[3]), d_new);
    if (plog) {
      double score = hv_phase_dlog_dg(phase, cos_theta);
      if (grid->uniform) {
        hv_path_log_add_at(plog, HV_LOG_PHASE, r.p, score); /* voxel found when applied */
      } else {
        hv_path_log_add(plog, HV_LOG_PHASE, r.k, score);
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
