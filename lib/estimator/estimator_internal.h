/* The estimator's state: tunables and the last render's statistics. */
#ifndef HV_ESTIMATOR_INTERNAL_H
#define HV_ESTIMATOR_INTERNAL_H

#include <stdbool.h>

#include "hetinv/estimator.h"

struct hetinv_estimator {
  hetinv_context_t *ctx;
  double param[HETINV_ESTIMATOR_PARAM_COUNT_];
  bool has_stats;
  hetinv_render_stats_t stats;
  /* Calibration gain (gain.c): the mode, and the gains of the last
   * successful loss gradient (gain_count 0: none). */
  hetinv_gain_mode_t gain_mode;
  double *gains;
  size_t gain_count, gain_capacity;
  /* Gradient passes' voxel-sized scratch, kept between calls (grad_scratch.h). */
  struct hv_grad_scratch *grad_scratch;
  /* The passes' grid arrays, kept between calls (transport/grid_store.h). */
  struct hv_grid_store *grid_store;
};

/* "HETINV_ESTIMATOR_PHOTONS", ..., for messages of other modules. */
const char *hv_estimator_param_name(hetinv_estimator_param_t param);

#endif
