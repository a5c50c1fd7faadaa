/* The optional smoothness prior (HETINV_OPTIMIZER_SMOOTHNESS): a Tikhonov
 * penalty on the gradient of π over its cell grid, added to the loss and
 * to its gradient before each step. */
#include "optimize/optimizer_internal.h"

/* R(π) = λ Σ_p Σ_axes a Σ_(i, i+e_a) (n_a² / N) (u_i − u_j)², u = π / s
 * (s: the entry's scale, its box width), n_a cells along axis a, N cells in
 * all: the Dirichlet energy ∫|∇u|² over the box taken as the unit cube, so
 * a smooth field costs the same at every level of a multi-resolution
 * schedule, and λ is in the loss's units. */
double hv_smoothness_add(const hetinv_optimizer_t *opt, const hetinv_param_map_t *map,
                         const double *pi, double *grad) {
  double lambda = opt->param[HETINV_OPTIMIZER_SMOOTHNESS];
  if (!(lambda > 0.0)) return 0.0;
  int32_t dims[3] = {1, 1, 1};
  hetinv_param_map_get_dims(map, dims);
  size_t cells = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
  size_t blocks = opt->k / cells; /* free parameters: π is parameter-major */
  size_t stride[3] = {1, (size_t)dims[0], (size_t)dims[0] * (size_t)dims[1]};
  double penalty = 0.0;
  for (size_t b = 0; b < blocks; ++b) {
    for (int a = 0; a < 3; ++a) {
      if (dims[a] < 2) continue;
      double w = lambda * (double)dims[a] * (double)dims[a] / (double)cells;
      for (size_t c = 0; c < cells; ++c) {
        int32_t along = (int32_t)(c / stride[a] % (size_t)dims[a]);
        if (along + 1 == dims[a]) continue;
        size_t i = b * cells + c, j = i + stride[a];
        double si = opt->scale[i], sj = opt->scale[j];
        double d = pi[i] / si - pi[j] / sj;
        penalty += w * d * d;
        grad[i] += 2.0 * w * d / si;
        grad[j] -= 2.0 * w * d / sj;
      }
    }
  }
  return penalty;
}
