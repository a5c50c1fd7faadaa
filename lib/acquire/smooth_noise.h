/* Fractal value noise from the counter-based generator: random values at
 * the points of an integer lattice, interpolated with the quintic
 * smoothstep 6t⁵ − 15t⁴ + 10t³ (so the field is C²), summed over octaves
 * whose lattice spacing and amplitude halve each time. Each lattice point's
 * values are one Philox block keyed by (seed, the point, the octave), so a
 * value anywhere can be computed alone, in any order. */
#ifndef HV_SMOOTH_NOISE_H
#define HV_SMOOTH_NOISE_H

#include <stdint.h>

/* Lattice points per axis are < this (their indices are packed into the
 * 48-bit stream index). */
#define HV_NOISE_LATTICE_LIMIT 4096

/* Independent fields evaluated at once (the four words of a Philox block). */
#define HV_NOISE_CHANNELS 4

typedef struct hv_smooth_noise {
  uint64_t seed;
  uint32_t domain;       /* an HV_RNG_DOMAIN_* constant */
  uint32_t stream_base;  /* octave o uses stream stream_base + o */
  int32_t octaves;       /* >= 1 */
  double origin[3];      /* where lattice point (0, 0, 0) is */
  double spacing;        /* lattice spacing of octave 0 (> 0) */
} hv_smooth_noise_t;

/* Lattice cells per axis that the finest octave needs to cover a box of
 * side @p extent from the origin (callers check it against the limit). */
double hv_smooth_noise_cells(const hv_smooth_noise_t *n, double extent);

/* The HV_NOISE_CHANNELS fields at point x (at or beyond the origin along
 * every axis), each in [0, 1]. */
void hv_smooth_noise_eval(const hv_smooth_noise_t *n, const double x[3],
                          double out[HV_NOISE_CHANNELS]);

#endif
