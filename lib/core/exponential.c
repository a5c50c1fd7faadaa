#include "core/exponential.h"

/* Right edge of the base layer and the common area of every layer, for 256
 * layers under exp(-x) (Marsaglia & Tsang 2000, Table 1). */
#define HV_ZIG_R 7.69711747013104972
#define HV_ZIG_V 3.949659822581572e-3

void hv_exp_table_init(hv_exp_table_t *t) {
  /* Layer 0 is the base strip together with the tail beyond r. */
  t->x[0] = HV_ZIG_V / exp(-HV_ZIG_R);
  t->x[1] = HV_ZIG_R;
  for (int i = 1; i < HV_ZIGGURAT_LAYERS - 1; ++i) {
    t->x[i + 1] = -log(HV_ZIG_V / t->x[i] + exp(-t->x[i]));
  }
  t->x[HV_ZIGGURAT_LAYERS] = 0.0;
  for (int i = 0; i <= HV_ZIGGURAT_LAYERS; ++i) t->f[i] = exp(-t->x[i]); /* f[0]: unused */
}

double hv_exp_sample_slow(const hv_exp_table_t *t, int layer, double z, hv_rng_t *rng) {
  for (;;) {
    if (layer == 0) {
      /* Base strip beyond r: the tail, memoryless, is r + Exp(1). */
      if (z >= HV_ZIG_R) return HV_ZIG_R - log(hv_rng_uniform_open(rng));
    } else {
      /* Wedge between layer i's rectangle and the curve: accept under exp(-z). */
      double y = t->f[layer] + hv_rng_uniform(rng) * (t->f[layer + 1] - t->f[layer]);
      if (y < exp(-z)) return z;
    }
    uint64_t bits = hv_rng_u64(rng);
    layer = (int)(bits & 0xff);
    z = (double)(bits >> 11) * 0x1p-53 * t->x[layer];
    if (z < t->x[layer + 1]) return z;
  }
}
