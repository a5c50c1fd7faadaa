/* What an efficient unbiased recovery would score against a worst-voxel
 * target, from the bound alone: how many of a volume's misses the data
 * predict, so that a batch's pass count can be read against what its data
 * allow (docs/results/seeds.md). Fig. 4's cells apply the same model to
 * their rule with its allowance (examples/experiments/verdict.c). */
#include <math.h>

#include "recon.h"

void recon_bound_efficient(const recon_bound_t *b, size_t voxels, double max_rel, recon_efficient_t *out) {
  const double none = (double)NAN;
  *out = (recon_efficient_t){.pass = b->done ? 1.0 : none, .pass_at_most = b->done ? 1.0 : none};
  for (int p = 0; p < 3; ++p) {
    out->over_max[p] = b->done ? 0.0 : none;
    const double *rel = recon_bound_per_voxel(b, p);
    for (size_t v = 0; b->done && v < voxels; ++v) {
      if (!(rel[v] >= 0.0)) continue; /* NaN: no bound; an infinite one misses surely */
      /* P(|z| > max_rel / bound), z standard normal; erfc(+inf) = 0 at a
       * zero bound, erfc(0) = 1 at an infinite one. */
      double miss = erfc(max_rel / rel[v] / sqrt(2.0));
      out->over_max[p] += miss;
      out->pass *= 1.0 - miss;
      out->pass_at_most = fmin(out->pass_at_most, 1.0 - miss);
    }
  }
}
