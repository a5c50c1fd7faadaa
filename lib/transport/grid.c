#include "transport/grid.h"

#include <string.h>

#include "core/alloc.h"
#include "core/context_internal.h"
#include "core/error.h"
#include "medium/medium_internal.h"

/* Grids below this many voxels are built on one thread: a parallel
 * region's start costs more than filling them. */
#define HV_GRID_PARALLEL_VOXELS ((size_t)1 << 16)

static size_t voxel_count(const hv_grid_t *g) { return (size_t)g->n[0] * (size_t)g->n[1] * (size_t)g->n[2]; }

static hetinv_result_t choose_tracking(hv_grid_t *grid, hv_grid_store_t *store);

hetinv_result_t hv_grid_build(const hetinv_medium_t *medium, hv_grid_store_t *store, hv_grid_t *out) {
  *out = (hv_grid_t){0};
  out->ctx = medium->ctx;
  size_t n = medium->voxel_count;
  size_t faces = (size_t)medium->dims[0] + (size_t)medium->dims[1] + (size_t)medium->dims[2] + 3;
  size_t voxel_bytes = 0, face_bytes = 0;
  /* Every entry is written below: no need to zero them first. */
  if (store != NULL) {
    hv_grid_slot_t *slot = hv_grid_store_slot(medium->ctx, store, 0, n, false);
    out->voxel = slot ? slot->voxel : NULL;
    out->borrowed = true;
  } else if (hv_mul_size(n, sizeof *out->voxel, &voxel_bytes)) {
    out->voxel = hv_alloc(medium->ctx, voxel_bytes);
  }
  if (hv_mul_size(faces, sizeof(double), &face_bytes)) out->face_storage = hv_alloc(medium->ctx, face_bytes);
  if (out->voxel == NULL || out->face_storage == NULL) {
    hv_grid_release(out);
    return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_MEMORY,
                   "cannot allocate the tracking grid of %zu voxels", n);
  }
  const double *sa = medium->values[HETINV_PARAM_SIGMA_A], *ss = medium->values[HETINV_PARAM_SIGMA_S];
  const double *g = medium->values[HETINV_PARAM_G];
  /* On every thread of the context, in blocks: a large grid's records are
   * then first touched (paged in) and filled in parallel, which is what a
   * forward pass of a uniform 100³ grid spends a sixth of its time on with
   * one thread. Each record depends on its voxel alone. */
#pragma omp parallel for num_threads(medium->ctx->thread_count) schedule(static) if (n >= HV_GRID_PARALLEL_VOXELS)
  for (size_t i = 0; i < n; ++i) {
    double st = sa[i] + ss[i];
    out->voxel[i] = (hv_voxel_t){.sigma_t = st,
                                 .inv_sigma_t = 1.0 / st,
                                 .albedo = st > 0.0 ? ss[i] / st : 0.0,
                                 .g = g[i]};
  }
  const hv_voxel_t *v0 = &out->voxel[0];
  int uniform_g = 1, uniform_rest = 1;
  out->inv_sigma_t = v0->inv_sigma_t;
#pragma omp parallel for num_threads(medium->ctx->thread_count) schedule(static) \
    reduction(&& : uniform_g, uniform_rest) if (n >= HV_GRID_PARALLEL_VOXELS)
  for (size_t i = 1; i < n; ++i) {
    uniform_g = uniform_g && out->voxel[i].g == v0->g;
    uniform_rest = uniform_rest && out->voxel[i].sigma_t == v0->sigma_t && out->voxel[i].albedo == v0->albedo;
  }
  out->uniform = uniform_g && uniform_rest;
  out->uniform_g = uniform_g;
  out->sigma_s = ss;
  int64_t stride = 1;
  double *face = out->face_storage;
  for (int a = 0; a < 3; ++a) {
    out->lo[a] = medium->box_min[a];
    out->hi[a] = medium->box_max[a];
    out->n[a] = medium->dims[a];
    out->h[a] = (out->hi[a] - out->lo[a]) / out->n[a];
    out->inv_h[a] = out->n[a] / (out->hi[a] - out->lo[a]);
    out->stride[a] = stride;
    stride *= out->n[a];
    for (int32_t i = 0; i < out->n[a]; ++i) face[i] = out->lo[a] + (double)i * out->h[a];
    face[out->n[a]] = out->hi[a];
    out->face[a] = face;
    face += out->n[a] + 1;
  }
  out->eta = medium->eta;
  out->eta_out = medium->eta_out;
  hetinv_result_t r = choose_tracking(out, store);
  if (r != HETINV_SUCCESS) hv_grid_release(out);
  return r;
}

/* Nanoseconds per event on this machine's kernel (one thread, A1-het of
 * hetinv-bench-forward): a tentative collision of delta tracking (locate,
 * draws, test), a voxel crossing and a flight's stepping set-up. Only their
 * ratios matter. */
#define HV_COST_TENTATIVE 12.0
#define HV_COST_CROSSING 27.0
#define HV_COST_FLIGHT 15.0

/* Sets grid->delta by the cost per unit length of either tracking: delta
 * tracking pays one tentative collision per 1/σ̄, stepping one crossing per
 * voxel face (Σ_a E|d_a| / h_a = Σ_a 1/(2 h_a) for isotropic directions)
 * and a set-up per collision (σt's mean), and builds its byte table. */
static hetinv_result_t choose_tracking(hv_grid_t *grid, hv_grid_store_t *store) {
  if (grid->uniform) { /* stepping is not needed, nor delta tracking */
    grid->majorant = grid->voxel[0].sigma_t;
    grid->inv_majorant = 1.0 / grid->majorant;
    return HETINV_SUCCESS;
  }
  size_t n = voxel_count(grid);
  /* σt's sum in a fixed number of blocks added in order: the same bits
   * on any number of threads, so the choice never depends on it. */
  enum { BLOCKS = 64 };
  double max = 0.0, sum = 0.0, part[BLOCKS];
#pragma omp parallel for num_threads(grid->ctx->thread_count) schedule(static) reduction(max : max) \
    if (n >= HV_GRID_PARALLEL_VOXELS)
  for (int b = 0; b < BLOCKS; ++b) {
    double s = 0.0;
    for (size_t i = n * (size_t)b / BLOCKS; i < n * (size_t)(b + 1) / BLOCKS; ++i) {
      double st = grid->voxel[i].sigma_t;
      max = st > max ? st : max;
      s += st;
    }
    part[b] = s;
  }
  for (int b = 0; b < BLOCKS; ++b) sum += part[b];
  grid->majorant = max;
  grid->inv_majorant = 1.0 / max;
  double crossings = 0.0;
  for (int a = 0; a < 3; ++a) crossings += 0.5 / grid->h[a];
  double step_cost = HV_COST_CROSSING * crossings + HV_COST_FLIGHT * sum / (double)n;
  grid->delta = !grid->uniform && max > 0.0 && isfinite(max) && HV_COST_TENTATIVE * max <= step_cost;
  if (!grid->delta) return HETINV_SUCCESS;
  if (store != NULL) {
    hv_grid_slot_t *slot = hv_grid_store_slot(grid->ctx, store, 0, n, true);
    grid->sigma_t_q = slot ? slot->sigma_t_q : NULL;
  } else {
    grid->sigma_t_q = hv_alloc(grid->ctx, n);
  }
  if (grid->sigma_t_q == NULL) {
    return HV_FAIL(grid->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the majorant table of %zu voxels", n);
  }
#pragma omp parallel for num_threads(grid->ctx->thread_count) schedule(static) if (n >= HV_GRID_PARALLEL_VOXELS)
  for (size_t i = 0; i < n; ++i) {
    double q = floor(256.0 * (grid->voxel[i].sigma_t / max));
    grid->sigma_t_q[i] = (uint8_t)(q < 255.0 ? q : 255.0);
  }
  return HETINV_SUCCESS;
}

void hv_grid_release(hv_grid_t *grid) {
  if (!grid->borrowed) {
    hv_free(grid->ctx, grid->voxel);
    hv_free(grid->ctx, grid->sigma_t_q);
  }
  hv_free(grid->ctx, grid->face_storage);
  hv_free(grid->ctx, grid->axis_depth_storage);
  grid->sigma_t_q = NULL;
  grid->voxel = NULL;
  grid->face_storage = NULL;
  grid->axis_depth_storage = NULL;
  for (int f = 0; f < 6; ++f) grid->axis_depth[f] = NULL;
}

size_t hv_grid_voxel_bytes(const hv_grid_t *g) {
  size_t n = voxel_count(g);
  return n * (sizeof *g->voxel + (g->sigma_t_q ? 1 : 0));
}

bool hv_grid_copy_take(const hv_grid_t *g, hv_grid_store_t *store, int i, hv_grid_t *copy) {
  hv_grid_slot_t *slot = hv_grid_store_slot(g->ctx, store, i, voxel_count(g), g->sigma_t_q != NULL);
  if (slot == NULL) return false;
  *copy = *g;
  copy->voxel = slot->voxel;
  copy->sigma_t_q = g->sigma_t_q ? slot->sigma_t_q : NULL;
  copy->borrowed = true;
  return true;
}

void hv_grid_copy_fill(const hv_grid_t *g, hv_grid_t *copy) {
  size_t n = voxel_count(g);
  memcpy(copy->voxel, g->voxel, n * sizeof *g->voxel);
  if (g->sigma_t_q) memcpy(copy->sigma_t_q, g->sigma_t_q, n);
}

/* One table: along axis a toward its face `up`, each line of voxels summed
 * from the box's face inward. */
static void axis_depth_fill(const hv_grid_t *g, int a, int up, double *out) {
  int b = (a + 1) % 3, c = (a + 2) % 3;
  int64_t step = up ? -g->stride[a] : g->stride[a]; /* inward */
  int32_t first = up ? g->n[a] - 1 : 0;
  for (int32_t ic = 0; ic < g->n[c]; ++ic) {
    for (int32_t ib = 0; ib < g->n[b]; ++ib) {
      int64_t k = ic * g->stride[c] + ib * g->stride[b] + first * g->stride[a];
      double depth = 0.0;
      for (int32_t i = 0; i < g->n[a]; ++i, k += step) {
        out[k] = depth;
        depth += g->voxel[k].sigma_t * g->h[a];
      }
    }
  }
}

hetinv_result_t hv_grid_build_axis_depths(hv_grid_t *grid, uint32_t faces) {
  faces &= 0x3fu;
  if (grid->uniform || faces == 0) return HETINV_SUCCESS;
  size_t n = voxel_count(grid);
  size_t tables = 0, bytes = 0;
  for (int f = 0; f < 6; ++f) tables += (faces >> f) & 1u;
  if (hv_mul_size(n, tables * sizeof(double), &bytes)) grid->axis_depth_storage = hv_alloc(grid->ctx, bytes);
  if (grid->axis_depth_storage == NULL) {
    return HV_FAIL(grid->ctx, HETINV_ERROR_OUT_OF_MEMORY,
                   "cannot allocate %zu optical-depth tables of %zu voxels", tables, n);
  }
  double *t = grid->axis_depth_storage;
  for (int f = 0; f < 6; ++f) {
    if (!((faces >> f) & 1u)) continue;
    axis_depth_fill(grid, f / 2, f % 2, t);
    grid->axis_depth[f] = t;
    t += n;
  }
  return HETINV_SUCCESS;
}
