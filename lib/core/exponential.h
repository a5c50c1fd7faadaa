/* Exponential variates (free-flight optical depths) by the ziggurat method
 * (Marsaglia & Tsang 2000) with 256 layers: 98.9 % of draws cost a table
 * read, a multiplication and a comparison, where -log(u) costs a libm call
 * (a quarter of the photon loop's time). Deterministic: the layers are a
 * table built once per render, and the rare slow path draws its extra
 * numbers from the photon's own stream. */
#ifndef HV_EXPONENTIAL_H
#define HV_EXPONENTIAL_H

#include <math.h>
#include <stdint.h>

#include "core/rng.h"

#define HV_ZIGGURAT_LAYERS 256

typedef struct hv_exp_table {
  double x[HV_ZIGGURAT_LAYERS + 1]; /* layer i spans [0, x[i]); x[256] = 0 */
  double f[HV_ZIGGURAT_LAYERS + 1]; /* exp(-x[i]) */
} hv_exp_table_t;

void hv_exp_table_init(hv_exp_table_t *t);

/* The slow path: the wedge test, the tail, or a retry. */
double hv_exp_sample_slow(const hv_exp_table_t *t, int layer, double z, hv_rng_t *rng);

/* An Exp(1) variate from 64 random bits: 8 pick the layer, 53 the position
 * within it; `rng` is used only on the slow path. */
static inline double hv_exp_sample(const hv_exp_table_t *t, uint64_t bits, hv_rng_t *rng) {
  int layer = (int)(bits & 0xff);
  double z = (double)(bits >> 11) * 0x1p-53 * t->x[layer];
  if (z < t->x[layer + 1]) return z; /* under the next layer: inside the curve */
  return hv_exp_sample_slow(t, layer, z, rng);
}

#endif
