/* A camera recording the render (the scene's "noise"): each row's values
 * become what a sensor with that noise model records, one exposure per
 * row, as hetinv-reconstruct's simulated acquisition makes them, so that
 * a preset written as files renders to its simulated data bit for bit. */
#ifndef HETINV_RENDER_CAMERA_H
#define HETINV_RENDER_CAMERA_H

#include "scene.h"

/* Replaces values[i] by the recorded value and std_errors[i] by the
 * recorded value's standard error combined with the render's own,
 * hypot(camera, Monte Carlo). Value i draws from the stream keyed by
 * (noise.seed, i), i its index in the scene's measurement values. A row
 * nothing reached keeps its zeros (its exposure is undefined). Returns 0,
 * or -1 with jr's message naming the row. */
int camera_record(const scene_t *scene, hetinv_context_t *ctx, double *values, double *std_errors, jr_t *jr);

#endif
