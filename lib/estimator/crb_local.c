/* The local Cramér–Rao bound (bound.h, hetinv_fisher_local_crb): for each
 * cell of the map, the bound of its entries when only the entries of the
 * cells within a Chebyshev radius are unknown. Windows of neighbouring
 * cells overlap, so each cell inverts its own small matrix. */
#include <math.h>
#include <stdlib.h>

#include "core/alloc.h"
#include "core/error.h"
#include "estimator/spd.h"
#include "hetinv/bound.h"
#include "param/param_map_internal.h"

HETINV_API hetinv_result_t hetinv_fisher_local_crb(const hetinv_param_map_t *map, const double *fisher,
                                                   size_t k, int32_t radius, double *sd) {
  HV_API_ENTER();
  if (map == NULL) return HV_FAIL(NULL, HETINV_ERROR_NULL_ARGUMENT, "'map' is NULL");
  const hetinv_context_t *ctx = hv_param_map_context(map);
  if (fisher == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'fisher' is NULL");
  if (sd == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'sd' is NULL");
  if (k != hetinv_param_map_size(map)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "k is %zu; the map has %zu entries", k,
                   hetinv_param_map_size(map));
  }
  if (radius < 0 || radius > 1024) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "radius is %d; expected 0 to 1024", (int)radius);
  }
  int32_t dims[3];
  hetinv_param_map_get_dims(map, dims);
  size_t cells = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
  size_t blocks = cells ? k / cells : 0; /* free parameters: entry f·cells + cell */
  size_t side[3], window = blocks;
  for (int a = 0; a < 3; ++a) {
    side[a] = (size_t)(2 * radius + 1) < (size_t)dims[a] ? (size_t)(2 * radius + 1) : (size_t)dims[a];
    window *= side[a];
  }
  if (window > HETINV_FISHER_MAX_ENTRIES) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "radius %d makes windows of %zu entries; at most %d (a smaller radius)", (int)radius,
                   window, HETINV_FISHER_MAX_ENTRIES);
  }
  size_t *idx = hv_calloc(ctx, window ? window : 1, sizeof(size_t));
  double *A = hv_calloc(ctx, window > 0 ? window * window : 1, sizeof(double));
  double *scratch = hv_calloc(ctx, 2 * window + 1, sizeof(double));
  double *out = hv_calloc(ctx, window + 1, sizeof(double));
  hetinv_result_t r = HETINV_SUCCESS;
  if (!(idx && A && scratch && out)) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate windows of %zu entries", window);
  }
  for (size_t c = 0; r == HETINV_SUCCESS && c < cells; ++c) {
    int32_t at[3] = {(int32_t)(c % (size_t)dims[0]), (int32_t)(c / (size_t)dims[0] % (size_t)dims[1]),
                     (int32_t)(c / ((size_t)dims[0] * (size_t)dims[1]))};
    /* The window's entries with information (F_ii > 0); entries never
     * seen (F_ii = 0) have an infinite bound and are left out. */
    size_t m = 0;
    for (int32_t z = at[2] - radius; z <= at[2] + radius; ++z) {
      for (int32_t y = at[1] - radius; y <= at[1] + radius; ++y) {
        for (int32_t x = at[0] - radius; x <= at[0] + radius; ++x) {
          if (x < 0 || y < 0 || z < 0 || x >= dims[0] || y >= dims[1] || z >= dims[2]) continue;
          size_t cell = (size_t)x + (size_t)dims[0] * ((size_t)y + (size_t)dims[1] * (size_t)z);
          for (size_t f = 0; f < blocks; ++f) {
            size_t i = f * cells + cell;
            if (fisher[i * k + i] > 0.0) idx[m++] = i;
          }
        }
      }
    }
    for (size_t i = 0; i < m; ++i) {
      for (size_t j = 0; j < m; ++j) A[i * m + j] = fisher[idx[i] * k + idx[j]];
    }
    bool pd = hv_spd_inverse_diagonal(A, m, scratch, out);
    for (size_t f = 0; f < blocks; ++f) {
      size_t i = f * cells + c;
      sd[i] = fisher[i * k + i] == 0.0 ? (double)INFINITY : (double)NAN;
      for (size_t q = 0; pd && q < m; ++q) {
        if (idx[q] == i) sd[i] = sqrt(out[q]);
      }
    }
  }
  hv_free(ctx, idx);
  hv_free(ctx, A);
  hv_free(ctx, scratch);
  hv_free(ctx, out);
  return r;
}

HETINV_API hetinv_result_t hetinv_fisher_blocks_crb(const hetinv_param_map_t *map, const double *blocks,
                                                    size_t k, double *sd) {
  HV_API_ENTER();
  if (map == NULL) return HV_FAIL(NULL, HETINV_ERROR_NULL_ARGUMENT, "'map' is NULL");
  const hetinv_context_t *ctx = hv_param_map_context(map);
  if (blocks == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'blocks' is NULL");
  if (sd == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'sd' is NULL");
  if (k != hetinv_param_map_size(map)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "k is %zu; the map has %zu entries", k,
                   hetinv_param_map_size(map));
  }
  int32_t dims[3];
  hetinv_param_map_get_dims(map, dims);
  size_t cells = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
  size_t P = cells ? k / cells : 0;
  /* P ≤ 3 (σa, σs, g): the block and its scratch fit on the stack. */
  double A[9], scratch[7], out[4];
  size_t idx[3];
  for (size_t c = 0; c < cells; ++c) {
    const double *B = blocks + c * P * P;
    size_t m = 0;
    for (size_t a = 0; a < P && a < 3; ++a) {
      if (B[a * P + a] > 0.0) idx[m++] = a;
    }
    for (size_t i = 0; i < m; ++i) {
      for (size_t j = 0; j < m; ++j) A[i * m + j] = B[idx[i] * P + idx[j]];
    }
    bool pd = m > 0 && hv_spd_inverse_diagonal(A, m, scratch, out);
    for (size_t a = 0; a < P; ++a) sd[a * cells + c] = B[a * P + a] == 0.0 ? (double)INFINITY : (double)NAN;
    for (size_t q = 0; pd && q < m; ++q) sd[idx[q] * cells + c] = sqrt(out[q]);
  }
  return HETINV_SUCCESS;
}
