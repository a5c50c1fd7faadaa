/* The photon loop: light tracing from an emitter through the voxel grid,
 * scoring hemispherical detectors at exits and orthographic sensors by
 * next-event connections at every scattering vertex. */
#ifndef HV_TRACER_H
#define HV_TRACER_H

#include <stdint.h>

#include "core/rng.h"
#include "transport/grid.h"
#include "transport/plan.h"

/* Per-photon statistics slots of a tally (fractions of emitted power). */
enum hv_stat {
  HV_STAT_SPECULAR = 0,
  HV_STAT_ABSORBED = 1,
  HV_STAT_ESCAPED = 2, /* 6 slots, one per face */
  HV_STAT_TRUNCATED = 8,
  HV_STAT_COUNT = 9
};

typedef struct hv_tracer {
  const hv_grid_t *grid;
  double roulette_weight, roulette_survival;
  int32_t min_scattering, max_scattering; /* max 0: unlimited */
} hv_tracer_t;

/* Where one batch of photons adds what it scores. */
typedef struct hv_tally {
  double *values;    /* the set's value layout */
  double *ballistic; /* same layout, or NULL */
  double stats[HV_STAT_COUNT];
} hv_tally_t;

void hv_trace_photon(const hv_tracer_t *t, const hv_plan_t *plan, hv_rng_t *rng, hv_tally_t *tally);

#endif
