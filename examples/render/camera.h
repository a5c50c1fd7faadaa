/* A camera recording the render (the scene's "noise"): each row's values
 * become what a sensor with that noise model records, one exposure per
 * row. hetinv-reconstruct's simulated acquisition takes its shots through
 * the same camera_shoot_row, so that a preset written as files renders to
 * its simulated data bit for bit. */
#ifndef HETINV_RENDER_CAMERA_H
#define HETINV_RENDER_CAMERA_H

#include <stdbool.h>

#include "scene.h"

/* One shot of row `row` of `set`: out[i] (i over the row's values, out
 * pointing at the row's first) is what the model records of clean[i] and
 * camera_se[i] (NULL: not wanted) its standard error; value i draws from
 * the stream keyed by (model seed, the value's index in the set), so one
 * row's noise does not depend on the others. out may be clean. A row
 * nothing reached is left alone (*lit false): its exposure is undefined.
 * *exposure (NULL: not wanted) is the shot's. */
hetinv_result_t camera_shoot_row(hetinv_context_t *ctx, const hetinv_noise_model_t *model,
                                 const hetinv_measurements_t *set, int32_t row, const double *clean, double *out,
                                 double *camera_se, double *exposure, bool *lit);

/* Replaces values[i] by the recorded value and std_errors[i] by the
 * recorded value's standard error combined with the render's own,
 * hypot(camera, Monte Carlo). A row nothing reached keeps its zeros.
 * Returns 0, or -1 with jr's message naming the row. */
int camera_record(const scene_t *scene, hetinv_context_t *ctx, double *values, double *std_errors, jr_t *jr);

#endif
