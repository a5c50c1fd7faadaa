/* A sensor kind, as the photon loop sees it: its two scoring hooks, one at
 * a scattering vertex and one at a boundary exit, the box of vertices
 * the first can score from, what it precomputes per (emitter, sensor)
 * when a render is planned, and the axis-parallel walks it makes (so the
 * grid can tabulate them). Each kind defines one
 * hv_sensor_kind_t in its file of lib/sensors/ and sets it on the sensors
 * it creates (hv_sensor_new); transport never names a kind. Adding a kind
 * is that one file and its create function's prototype in
 * hetinv/sampling.h (lib/CMakeLists.txt builds every file of lib/sensors/);
 * the test suite then wants the new public function in the error
 * attribution table (tests/unit/core_error_attribution.c) and in the
 * Python binding's prototypes (bindings/python/hetinv/_lib.py). */
#ifndef HV_SENSOR_KIND_H
#define HV_SENSOR_KIND_H

#include <stdint.h>

#include "medium/phase.h"
#include "transport/tracer.h"

/* A photon leaving the medium: where it crosses the face (ray->p, with
 * its direction inside ray->d), the cosine of its refracted direction with
 * the face normal, η_out/η, its weight and pathlength, and how often it
 * scattered. */
typedef struct hv_exit {
  const hv_ray_t *ray;
  hetinv_face_t face;
  double cos_t, eta, w, tau;
  int32_t scatterings;
} hv_exit_t;

typedef struct hv_sensor_kind hv_sensor_kind_t;

struct hv_sensor_kind {
  const char *name;
  /* When a render is planned: fills t->cache (the kind's data per emitter
   * and sensor). NULL: nothing to precompute. */
  void (*prepare)(hv_sensor_target_t *t);
  /* At a scattering vertex (ray: position and direction of arrival, w
   * the weight after the albedo, phase the vertex's phase function, tau
   * the pathlength so far): scores the light the vertex sends to the
   * sensor (next-event estimation). rng is the photon's stream, for rare
   * draws (hv_rng_uniform). NULL: the kind scores no vertex. */
  void (*at_vertex)(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_sensor_target_t *t,
                    const hv_ray_t *vertex, double w, hv_phase_t phase, double tau, hv_rng_t *rng,
                    hv_tally_t *tally);
  /* The box [lo, hi] that holds every vertex from which at_vertex can
   * score or draw: the photon loop does not call at_vertex at a vertex
   * outside it, so the box must be conservative (a camera along a face
   * normal reaches only the prism over its pixels: in a 2D section's row,
   * 1–4 % of the vertices; the calls that returned at once were most of
   * a reconstruction's connection time). NULL: everywhere. */
  void (*reach)(const hetinv_sensor_t *s, double lo[3], double hi[3]);
  /* At a boundary exit of a path whose scattering count is scored. NULL:
   * the kind scores no exit. */
  void (*at_exit)(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_sensor_target_t *t,
                  const hv_exit_t *exit, hv_tally_t *tally);
  /* The directions of travel (bit 2a + up, as hetinv_face_t) along which
   * the kind's at_vertex walks axis-parallel rays to the boundary
   * (hv_ray_to_boundary): the render then tabulates the optical depth
   * along them (hv_grid_build_axis_depths). NULL: none. */
  uint32_t (*axis_walks)(const hetinv_sensor_t *s);
  /* Continues the FNV-1a hash h (core/hash.h) over what the sensor was made
   * from beyond what every sensor has (face, pixel grid): its arguments,
   * not its derived data. Optimizer checkpoints store the hash
   * (estimator/set_hash.c), so the same arguments must hash alike in every
   * library version. NULL: nothing more. */
  uint64_t (*fingerprint)(const hetinv_sensor_t *s, uint64_t h);
};

#endif
