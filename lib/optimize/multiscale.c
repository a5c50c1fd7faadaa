/* The optional multi-scale step (HETINV_OPTIMIZER_MULTISCALE): the
 * gradient of each entry gains α times the mean gradient of its block of
 * cells at every coarser scale, blocks of 2, 4, 8, ... cells along each
 * axis up to the whole grid. */
#include "optimize/optimizer_internal.h"

/* Cells of the block starting at cell start along an axis of n cells. */
static int32_t span(int32_t start, int32_t b, int32_t n) { return start + b <= n ? b : n - start; }

/* Cell c's block of b cells per axis on a grid of n cells (m blocks per
 * axis): its index, and in v the block's coordinates. */
static size_t block_of(size_t c, const int32_t n[3], int32_t b, const int32_t m[3], int32_t v[3]) {
  v[0] = (int32_t)(c % (size_t)n[0]) / b;
  v[1] = (int32_t)(c / (size_t)n[0] % (size_t)n[1]) / b;
  v[2] = (int32_t)(c / ((size_t)n[0] * (size_t)n[1])) / b;
  return ((size_t)v[2] * (size_t)m[1] + (size_t)v[1]) * (size_t)m[0] + (size_t)v[0];
}

void hv_multiscale_apply(hetinv_optimizer_t *opt, const hetinv_param_map_t *map, const uint8_t *frozen) {
  double alpha = opt->param[HETINV_OPTIMIZER_MULTISCALE];
  if (!(alpha > 0.0)) return;
  int32_t n[3] = {1, 1, 1};
  hetinv_param_map_get_dims(map, n);
  size_t cells = (size_t)n[0] * (size_t)n[1] * (size_t)n[2];
  if (cells < 2) return;
  size_t blocks = opt->k / cells; /* free parameters: π is parameter-major */
  double *sum = opt->multiscale, *grad = opt->grad;
  /* Every level's block sums of the unchanged gradient first, one after
   * the other in `sum` (Σ over levels of Π ceil(n_a / b) < 2·cells blocks
   * per parameter: ceil adds at most one per axis and level), then the
   * means added. */
  size_t at = 0;
  int32_t levels = 0;
  for (int32_t b = 2;; b *= 2, ++levels) {
    int32_t m[3];
    for (int a = 0; a < 3; ++a) m[a] = (n[a] + b - 1) / b;
    size_t count = (size_t)m[0] * (size_t)m[1] * (size_t)m[2];
    for (size_t p = 0; p < blocks; ++p) {
      double *s = sum + at + p * count;
      for (size_t j = 0; j < count; ++j) s[j] = 0.0;
      for (size_t c = 0; c < cells; ++c) {
        size_t i = p * cells + c;
        int32_t v[3];
        if (!(frozen && frozen[i])) s[block_of(c, n, b, m, v)] += grad[i];
      }
    }
    at += blocks * count;
    if (count == 1) break;
  }
  at = 0;
  for (int32_t l = 0, b = 2; l <= levels; ++l, b *= 2) {
    int32_t m[3];
    for (int a = 0; a < 3; ++a) m[a] = (n[a] + b - 1) / b;
    size_t count = (size_t)m[0] * (size_t)m[1] * (size_t)m[2];
    for (size_t p = 0; p < blocks; ++p) {
      const double *s = sum + at + p * count;
      for (size_t c = 0; c < cells; ++c) {
        size_t i = p * cells + c;
        if (frozen && frozen[i]) continue;
        int32_t v[3];
        size_t at_block = block_of(c, n, b, m, v);
        /* Frozen cells count in the block's size: a mean over the cells
         * that move would weigh a block's few free cells up. */
        double size = (double)span(v[0] * b, b, n[0]) * span(v[1] * b, b, n[1]) * span(v[2] * b, b, n[2]);
        grad[i] += alpha * s[at_block] / size;
      }
    }
    at += blocks * count;
  }
}
