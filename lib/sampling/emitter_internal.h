/* Emitters: what the photon loop needs to launch a photon. */
#ifndef HV_EMITTER_INTERNAL_H
#define HV_EMITTER_INTERNAL_H

#include "core/rng.h"
#include "hetinv/sampling.h"
#include "sampling/geometry.h"

typedef enum hv_emitter_kind {
  HV_EMITTER_IDEAL,       /* one pencil beam (count = 1) */
  HV_EMITTER_COMBINATION, /* count pencil beams, chosen by weight */
  HV_EMITTER_AREA,        /* collimated, over a patterned rectangle of a face */
  HV_EMITTER_DIFFUSE,     /* cosine-weighted directions at one point of a face */
} hv_emitter_kind_t;

struct hetinv_emitter {
  hetinv_context_t *ctx;
  hv_geometry_t geo;
  hv_emitter_kind_t kind;
  double power;          /* total emitted power */
  int32_t count;         /* beams (ideal, combination) or pattern cells (area) */
  double *points;        /* beams: 3·count entry points on the boundary */
  hetinv_face_t *faces;  /* beams: entry face of each */
  double *directions;    /* beams: 3·count unit directions */
  double *cdf;           /* combination / area: cumulative weights, cdf[count-1] = 1 */
  hetinv_face_t face;    /* area, diffuse */
  double direction[3];   /* area: unit direction */
  double rect_min[2], rect_max[2]; /* area: lit rectangle; diffuse: the point in rect_min */
  int32_t pattern_width, pattern_height; /* area */
};

/* A photon leaving the emitter: where it meets the boundary, travelling
 * along the (outside) incident direction, with its weight relative to the
 * emitter's power (the tracer scales what it scores by the power, so that
 * statistics and Russian roulette work in fractions of the power). */
typedef struct hv_launch {
  double point[3];
  double direction[3];
  hetinv_face_t face;
  double weight;
} hv_launch_t;

void hv_emitter_sample(const hetinv_emitter_t *e, hv_rng_t *rng, hv_launch_t *out);

#endif
