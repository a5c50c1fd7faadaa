/* The photon loop: light tracing from an emitter through the voxel grid,
 * scoring every sensor through its kind's hooks (transport/sensor_kind.h)
 * at scattering vertices and at boundary exits. */
#ifndef HV_TRACER_H
#define HV_TRACER_H

#include <stdint.h>

#include "core/compiler.h"
#include "core/exponential.h"
#include "core/rng.h"
#include "transport/grid.h"
#include "transport/path_log.h"
#include "transport/path_jvp.h"
#include "transport/plan.h"

/* Per-photon statistics slots of a tally (fractions of emitted power). */
enum hv_stat {
  HV_STAT_SPECULAR = 0,
  HV_STAT_ABSORBED = 1,
  HV_STAT_ESCAPED = 2, /* 6 slots, one per face */
  HV_STAT_TRUNCATED = 8,
  HV_STAT_TRUNCATED_PATHS = 9, /* a count of paths, not a power */
  HV_STAT_COUNT = 10
};

typedef struct hv_tracer {
  const hv_grid_t *grid;
  const hv_exp_table_t *exp_table; /* free-flight optical depths */
  double roulette_weight, roulette_survival;
  int32_t min_scattering, max_scattering; /* max 0: unlimited */
} hv_tracer_t;

/* Gradient mode: instead of adding contributions c to values, each splat
 * weighs c by the cotangent (Σ over bins of cot·W_τ) and the path's scores
 * go to the voxel gradient (3 blocks of `voxels`: σa, σs, g). */
typedef struct hv_grad_tally {
  const double *cotangent; /* the set's value layout; NULL in tangent mode */
  double *grad;
  size_t voxels;
  hv_path_log_t path, chain; /* scratch of the current path and connection */
  /* The SIMD lanes' ring of photons' score logs (lanes.c), kept with
   * their room from batch to batch; NULL until a lanes pass needs them. */
  hv_path_log_t *lane_logs;
  /* Voxels whose gradient entries are (possibly) non-zero, so that the
   * reduction and the reset touch only those. */
  uint8_t *touched;
  int64_t *touched_list;
  size_t touched_count;
  hv_jvp_state_t jvp; /* tangent mode (transport/path_jvp.h); unused otherwise */
  char apart[HV_CACHE_GAP]; /* slots sit side by side in an array */
} hv_grad_tally_t;

/* Frees the tally's score logs (path, chain, the lanes' ring). */
void hv_grad_tally_release_logs(hv_grad_tally_t *gt);

/* Adds amount to entry (param block, voxel) of the tally's gradient. */
static inline void hv_grad_add(hv_grad_tally_t *gt, int param, int64_t voxel, double amount) {
  gt->grad[(size_t)param * gt->voxels + (size_t)voxel] += amount;
  if (!gt->touched[voxel]) {
    gt->touched[voxel] = 1;
    gt->touched_list[gt->touched_count++] = voxel;
  }
}

/* A segment's transmittance score: amount belongs to both σa and σs of
 * voxel. It is added to the σa block only, which receives nothing else;
 * hv_grad_fold_extinction adds that block to σs once per batch. One store
 * per voxel crossing instead of two, in one array instead of two. */
static inline void hv_grad_add_extinction(hv_grad_tally_t *gt, int64_t voxel, double amount) {
  gt->grad[(size_t)voxel] += amount;
  if (!gt->touched[voxel]) {
    gt->touched[voxel] = 1;
    gt->touched_list[gt->touched_count++] = voxel;
  }
}

/* Completes σs of the touched voxels with their extinction scores (the σa
 * block); call once, after the batch's photons and before reading σs. */
static inline void hv_grad_fold_extinction(hv_grad_tally_t *gt) {
  for (size_t i = 0; i < gt->touched_count; ++i) {
    size_t v = (size_t)gt->touched_list[i];
    gt->grad[gt->voxels + v] += gt->grad[v];
  }
}

/* Adds every entry's score times (log->cum - entry.cum) to the gradient. */
void hv_grad_apply_log(hv_grad_tally_t *gt, const hv_grid_t *grid, const hv_path_log_t *log);

/* Where one batch of photons adds what it scores. In tangent mode
 * (grad->jvp.tangents > 0) values holds T doubles per value of the set's
 * layout: value n, tangent t at values[n·T + t]. */
typedef struct hv_tally {
  /* Forward mode: the set's value layout. Tangent mode: the plan's own
   * values (hv_row_target_t::local), T doubles each. */
  double *values;
  double *ballistic; /* same layout, or NULL */
  hv_grad_tally_t *grad; /* NULL: forward mode; see hv_grad_tally_t */
  double stats[HV_STAT_COUNT];
  char apart[HV_CACHE_GAP]; /* slots sit side by side in an array */
} hv_tally_t;

void hv_trace_photon(const hv_tracer_t *t, const hv_plan_t *plan, hv_rng_t *rng, hv_tally_t *tally);

#endif
