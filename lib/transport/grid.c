#include "transport/grid.h"

#include "core/alloc.h"
#include "core/error.h"
#include "medium/medium_internal.h"

hetinv_result_t hv_grid_build(const hetinv_medium_t *medium, hv_grid_t *out) {
  *out = (hv_grid_t){0};
  out->ctx = medium->ctx;
  size_t n = medium->voxel_count;
  out->sigma_t = hv_calloc(medium->ctx, n, sizeof(double));
  out->albedo = hv_calloc(medium->ctx, n, sizeof(double));
  if (out->sigma_t == NULL || out->albedo == NULL) {
    hv_grid_release(out);
    return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_MEMORY,
                   "cannot allocate the tracking grid of %zu voxels", n);
  }
  const double *sa = medium->values[HETINV_PARAM_SIGMA_A], *ss = medium->values[HETINV_PARAM_SIGMA_S];
  for (size_t i = 0; i < n; ++i) {
    out->sigma_t[i] = sa[i] + ss[i];
    out->albedo[i] = out->sigma_t[i] > 0.0 ? ss[i] / out->sigma_t[i] : 0.0;
  }
  out->g = medium->values[HETINV_PARAM_G];
  out->uniform = 1;
  out->inv_sigma_t = 1.0 / out->sigma_t[0];
  for (size_t i = 1; i < n && out->uniform; ++i) {
    out->uniform = out->sigma_t[i] == out->sigma_t[0] && out->albedo[i] == out->albedo[0] &&
                   out->g[i] == out->g[0];
  }
  out->sigma_s = ss;
  int64_t stride = 1;
  for (int a = 0; a < 3; ++a) {
    out->lo[a] = medium->box_min[a];
    out->hi[a] = medium->box_max[a];
    out->n[a] = medium->dims[a];
    out->h[a] = (out->hi[a] - out->lo[a]) / out->n[a];
    out->inv_h[a] = out->n[a] / (out->hi[a] - out->lo[a]);
    out->stride[a] = stride;
    stride *= out->n[a];
  }
  out->eta = medium->eta;
  out->eta_out = medium->eta_out;
  return HETINV_SUCCESS;
}

void hv_grid_release(hv_grid_t *grid) {
  hv_free(grid->ctx, grid->sigma_t);
  hv_free(grid->ctx, grid->albedo);
  grid->sigma_t = grid->albedo = NULL;
}
