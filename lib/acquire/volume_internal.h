/* What the volume generators share: checking the target medium and the
 * value ranges, voxel centres, and the final write into the medium. */
#ifndef HV_VOLUME_INTERNAL_H
#define HV_VOLUME_INTERNAL_H

#include <stddef.h>

#include "hetinv/medium.h"

/* NULL_ARGUMENT for a NULL medium, INVALID_STATE for a committed one. */
hetinv_result_t hv_volume_check_medium(const hetinv_medium_t *medium);

/* Each parameter's range [lo[p], hi[p]]: finite, lo <= hi, and allowed by
 * the medium (σ >= 0, -1 < g < 1). Messages name "spec->lo[p] (name)". */
hetinv_result_t hv_volume_check_ranges(const hetinv_context_t *ctx,
                                       const double lo[3], const double hi[3]);

/* lo·(1 − t) + hi·t for t in [0, 1], clamped to [lo, hi]: exactly lo at
 * t = 0 and exactly hi at t = 1. */
double hv_volume_lerp(double lo, double hi, double t);

/* Centre coordinate of voxel i of n along [lo, hi]. */
static inline double hv_voxel_centre(double lo, double hi, int32_t n, int32_t i) {
  return lo + (hi - lo) * (((double)i + 0.5) / (double)n);
}

/* Writes the three arrays (voxel_count values each) into the medium with
 * hetinv_medium_set_grid; the values must already be valid. */
hetinv_result_t hv_volume_store(hetinv_medium_t *medium, double *const values[3]);

#endif
