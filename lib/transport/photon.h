/* The ends of a photon's life, shared by the scalar photon loop
 * (tracer.c) and the loop that traces photons in SIMD lanes (lanes.c):
 * entering the medium, and meeting its boundary from inside. Both loops
 * call these, so a photon's launch, its Fresnel draws and what its exit
 * scores are the same arithmetic in either. */
#ifndef HV_PHOTON_H
#define HV_PHOTON_H

#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "core/compiler.h"
#include "medium/fresnel.h"
#include "sampling/emitter_internal.h"
#include "transport/sensor_kind.h"
#include "transport/tracer.h"
#include "transport/walk.h"

/* Samples the emitter and refracts the launch into the medium: the ray r
 * (located), its weight *w, and *specular, the power the first surface
 * reflects (the caller adds it to HV_STAT_SPECULAR). Returns false if no
 * power enters (*w is then not > 0). */
HV_ALWAYS_INLINE static inline bool hv_photon_launch(const hv_tracer_t *tr, const hv_plan_t *plan, hv_rng_t *rng,
                                                     hv_ray_t *r, double *w, double *specular) {
  const hv_grid_t *grid = tr->grid;
  hv_launch_t launch;
  hv_emitter_sample(plan->emitter, rng, &launch);
  double n[3], cos_t;
  hv_face_normal(launch.face, n);
  double eta_in = grid->eta / grid->eta_out;
  double R = hv_fresnel_dielectric(fabs(launch.direction[hv_face_axis(launch.face)]), eta_in, &cos_t);
  *specular = launch.weight * R;
  *w = launch.weight * (1.0 - R);
  if (!(*w > 0.0)) return false;
  memcpy(r->p, launch.point, sizeof r->p);
  hv_refract_cos(launch.direction, n, eta_in, cos_t, r->d);
  hv_ray_locate(grid, r);
  return true;
}

/* A photon on face `face` from inside: whether the surface reflects it
 * (one uniform from rng unless R is 0 or 1). If it does, r->d is mirrored
 * and r re-located; if not, *cos_t is the cosine of the refracted
 * direction and *eta = η_out/η, for hv_photon_exit. */
HV_ALWAYS_INLINE static inline bool hv_photon_reflects(const hv_grid_t *grid, hv_rng_t *rng, hv_ray_t *r,
                                                       hetinv_face_t face, double *cos_t, double *eta) {
  int a = hv_face_axis(face);
  *eta = grid->eta_out / grid->eta;
  double R = hv_fresnel_dielectric(fabs(r->d[a]), *eta, cos_t);
  if (R > 0.0 && (R >= 1.0 || hv_rng_uniform(rng) < R)) {
    r->d[a] = -r->d[a];
    hv_ray_locate(grid, r);
    return true;
  }
  return false;
}

/* A photon leaving the medium: its weight to the face's escape statistic,
 * and, if its scattering count is scored, to every exit sensor. */
static inline void hv_photon_exit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_exit_t *leaving,
                                  hv_tally_t *tally) {
  tally->stats[HV_STAT_ESCAPED + leaving->face] += leaving->w;
  int32_t n = leaving->scatterings;
  bool counted = n >= tr->min_scattering && (tr->max_scattering == 0 || n <= tr->max_scattering);
  if (!counted) return;
  for (int32_t i = 0; i < plan->exit_count; ++i) {
    const hv_sensor_target_t *t = plan->at_exit[i];
    t->kind->at_exit(tr, plan, t, leaving, tally);
  }
}

#endif
