#include "acquire/smooth_noise.h"

#include <assert.h>
#include <math.h>

#include "core/rng.h"

double hv_smooth_noise_cells(const hv_smooth_noise_t *n, double extent) {
  return extent / n->spacing * ldexp(1.0, n->octaves - 1) + 2.0;
}

/* 6t⁵ − 15t⁴ + 10t³: 0 and 1 at the ends with zero first and second derivatives. */
static double quintic(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

/* The lattice values of point (i, j, k) of octave o. */
static philox4x32_ctr_t lattice(const hv_smooth_noise_t *n, uint64_t i, uint64_t j, uint64_t k,
                                int32_t o) {
  uint64_t index = i + HV_NOISE_LATTICE_LIMIT * (j + HV_NOISE_LATTICE_LIMIT * k);
  hv_rng_t rng = hv_rng_init_domain(n->seed, n->domain, index, n->stream_base + (uint32_t)o);
  return hv_rng_block(&rng);
}

void hv_smooth_noise_eval(const hv_smooth_noise_t *n, const double x[3],
                          double out[HV_NOISE_CHANNELS]) {
  for (int c = 0; c < HV_NOISE_CHANNELS; ++c) out[c] = 0.0;
  double amplitude = 1.0, total = 0.0, scale = 1.0 / n->spacing;
  for (int32_t o = 0; o < n->octaves; ++o, amplitude *= 0.5, scale *= 2.0) {
    uint64_t cell[3];
    double w[3];
    for (int a = 0; a < 3; ++a) {
      double u = fmax((x[a] - n->origin[a]) * scale, 0.0);
      double f = floor(u);
      assert(f + 1.0 < HV_NOISE_LATTICE_LIMIT);
      cell[a] = (uint64_t)f;
      w[a] = quintic(u - f);
    }
    double sum[HV_NOISE_CHANNELS] = {0.0, 0.0, 0.0, 0.0};
    for (int corner = 0; corner < 8; ++corner) {
      int bx = corner & 1, by = (corner >> 1) & 1, bz = corner >> 2;
      double weight = (bx ? w[0] : 1.0 - w[0]) * (by ? w[1] : 1.0 - w[1]) *
                      (bz ? w[2] : 1.0 - w[2]);
      philox4x32_ctr_t v = lattice(n, cell[0] + (uint64_t)bx, cell[1] + (uint64_t)by,
                                   cell[2] + (uint64_t)bz, o);
      for (int c = 0; c < HV_NOISE_CHANNELS; ++c) sum[c] += weight * hv_unit_from_u32(v.v[c]);
    }
    for (int c = 0; c < HV_NOISE_CHANNELS; ++c) out[c] += amplitude * sum[c];
    total += amplitude;
  }
  for (int c = 0; c < HV_NOISE_CHANNELS; ++c) out[c] = fmin(out[c] / total, 1.0);
}
