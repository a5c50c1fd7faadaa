/* A small scene shared by tests of the loss: a homogeneous 2 × 2 × 2 voxel
 * cube (10 mm, σa 0.05, σs 0.5, g 0.3, n 1.4), one beam, and two rows: a
 * 2 × 2 orthographic camera on the lit face, then the transmittance of the
 * opposite face (5 values). Every voxel's three parameters free; the
 * estimator at 1000 photons per emitter. */
#ifndef HETINV_SMALL_SCENE_H
#define HETINV_SMALL_SCENE_H

#include "test_support.h"

enum { SMALL_SCENE_VALUES = 5 };

typedef struct small_scene {
  hetinv_context_t *ctx;
  hetinv_medium_t *medium;
  hetinv_emitter_t *beam;
  hetinv_sensor_t *ortho, *transmit;
  hetinv_pathlength_t *steady;
  hetinv_measurements_t *set;
  hetinv_param_map_t *map;
  hetinv_estimator_t *est;
  size_t k; /* free parameters: 24 */
} small_scene_t;

/* Two threads; the context's seed and the estimator's batches as given. */
void small_scene_init(small_scene_t *s, uint64_t seed, int batches);
void small_scene_release(small_scene_t *s);

#endif
