/* Scoring a contribution into a sensor's rows, shared by the photon loop
 * and the sensor kinds' hooks (lib/sensors/). */
#ifndef HV_SCORE_H
#define HV_SCORE_H

#include "sampling/pathlength_internal.h"
#include "transport/tracer.h"

/* Scores contribution `value` at pathlength tau into pixel `pixel` of every
 * row of target t: added to dst (forward), or, in gradient mode, weighed by
 * the cotangent and added to the splat total of `log`. */
static inline void hv_score(const hv_plan_t *plan, const hv_sensor_target_t *t, hv_tally_t *tally, double *dst,
                            hv_path_log_t *log, int32_t pixel, double tau, double value) {
  value *= plan->emitter->power;
  hv_grad_tally_t *gt = tally->grad;
  for (int32_t i = 0; i < t->row_count; ++i) {
    const hv_row_target_t *row = &plan->rows[t->first_row + i];
    if (gt && gt->jvp.tangents > 0) {
      /* Tangent tallies hold the plan's own values only (row->local). */
      size_t T = (size_t)gt->jvp.tangents;
      hv_jvp_splat(&gt->jvp, &gt->path, log == &gt->chain ? log : NULL, row->pathlength, tau, value,
                   dst + ((size_t)row->local + (size_t)pixel) * T, (size_t)row->pixels * T);
    } else if (gt) {
      log->scored = true;
      log->cum += value * hv_pathlength_dot(row->pathlength, tau,
                                            tally->grad->cotangent + row->offset + pixel, row->pixels);
    } else {
      hv_pathlength_splat(row->pathlength, tau, value, dst + row->offset + pixel, row->pixels);
    }
  }
}

#endif
