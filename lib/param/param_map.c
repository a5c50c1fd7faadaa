/* Parameter maps: π ↔ voxels as a tensor product of three 1-D linear maps,
 * each voxel reading at most two cells per axis. */
#include <math.h>
#include <stdbool.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "hetinv/param.h"
#include "medium/medium_internal.h"
#include "param/param_map_internal.h"

typedef struct axis_map {
  int32_t *lo, *hi; /* per voxel: the two cells it reads */
  double *w_hi;     /* weight of `hi` (that of `lo` is 1 - w_hi) */
} axis_map_t;

struct hetinv_param_map {
  hetinv_context_t *ctx;
  uint32_t free_mask;
  int32_t free_count;
  hetinv_param_t free_params[HETINV_PARAM_COUNT];
  int32_t fine[3], cells[3];
  size_t cell_count, voxel_count;
  axis_map_t axis[3];
};

const hetinv_context_t *hv_param_map_context(const hetinv_param_map_t *map) { return map->ctx; }

HETINV_API void hetinv_param_map_destroy(hetinv_param_map_t **map) {
  HV_API_ENTER();
  if (map == NULL || *map == NULL) return;
  hetinv_param_map_t *m = *map;
  for (int a = 0; a < 3; ++a) {
    hv_free(m->ctx, m->axis[a].lo);
    hv_free(m->ctx, m->axis[a].hi);
    hv_free(m->ctx, m->axis[a].w_hi);
  }
  hv_free(m->ctx, m);
  *map = NULL;
}

/* kind: 'i' identity, 'c' coarse, 'b' broadcast along `bcast_axis`. */
static hetinv_result_t create(const hetinv_medium_t *medium, char kind,
                              const int32_t coarse[3], int32_t bcast_axis, uint32_t free_mask,
                              hetinv_param_map_t **out) {
  hetinv_context_t *ctx = medium->ctx;
  if (free_mask == 0 || (free_mask & ~(uint32_t)HETINV_FREE_ALL) != 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "free_mask is 0x%x; it must be a non-empty combination of HETINV_FREE(HETINV_PARAM_*) bits",
                   (unsigned)free_mask);
  }
  hetinv_param_map_t *m = hv_calloc(ctx, 1, sizeof *m);
  if (m == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a map");
  m->ctx = ctx;
  m->free_mask = free_mask;
  for (hetinv_param_t p = 0; p < HETINV_PARAM_COUNT; ++p) {
    if (free_mask & HETINV_FREE(p)) m->free_params[m->free_count++] = p;
  }
  m->voxel_count = medium->voxel_count;
  m->cell_count = 1;
  for (int a = 0; a < 3; ++a) {
    int32_t n = medium->dims[a];
    m->fine[a] = n;
    m->cells[a] = kind == 'c' ? coarse[a] : (kind == 'b' && a == bcast_axis ? 1 : n);
    m->cell_count *= (size_t)m->cells[a];
    axis_map_t *am = &m->axis[a];
    am->lo = hv_calloc(ctx, (size_t)n, sizeof(int32_t));
    am->hi = hv_calloc(ctx, (size_t)n, sizeof(int32_t));
    am->w_hi = hv_calloc(ctx, (size_t)n, sizeof(double));
    if (!am->lo || !am->hi || !am->w_hi) {
      hetinv_param_map_destroy(&m);
      return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate a map");
    }
    int32_t nc = m->cells[a];
    for (int32_t v = 0; v < n; ++v) {
      if (nc == n) {
        am->lo[v] = am->hi[v] = v;
      } else if (nc == 1) {
        am->lo[v] = am->hi[v] = 0;
      } else { /* cell-centred linear interpolation, clamped */
        double c = (v + 0.5) * nc / n - 0.5;
        c = c < 0.0 ? 0.0 : (c > nc - 1 ? nc - 1 : c);
        int32_t lo = (int32_t)floor(c);
        am->lo[v] = lo;
        am->hi[v] = lo + 1 < nc ? lo + 1 : lo;
        am->w_hi[v] = am->hi[v] == lo ? 0.0 : c - lo;
      }
    }
  }
  *out = m;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_param_map_create_identity(const hetinv_medium_t *medium,
                                                            uint32_t free_mask,
                                                            hetinv_param_map_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  return create(medium, 'i', NULL, -1, free_mask, out);
}

HETINV_API hetinv_result_t hetinv_param_map_create_coarse(const hetinv_medium_t *medium,
                                                          const int32_t coarse_dims[3],
                                                          uint32_t free_mask,
                                                          hetinv_param_map_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  HV_CHECK_NULL(medium->ctx, coarse_dims);
  for (int a = 0; a < 3; ++a) {
    if (coarse_dims[a] < 1 || coarse_dims[a] > medium->dims[a]) {
      return HV_FAIL(medium->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                     "coarse_dims[%d] is %d; it must be in [1, %d] (the medium's grid)", a,
                     (int)coarse_dims[a], (int)medium->dims[a]);
    }
  }
  return create(medium, 'c', coarse_dims, -1, free_mask, out);
}

HETINV_API hetinv_result_t hetinv_param_map_create_broadcast(const hetinv_medium_t *medium,
                                                             int32_t axis, uint32_t free_mask,
                                                             hetinv_param_map_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(medium ? medium->ctx : NULL, out);
  *out = NULL;
  HV_CHECK_NULL(NULL, medium);
  if (axis < 0 || axis > 2) {
    return HV_FAIL(medium->ctx, HETINV_ERROR_OUT_OF_RANGE, "axis is %d; it must be 0, 1 or 2", (int)axis);
  }
  return create(medium, 'b', NULL, axis, free_mask, out);
}

HETINV_API size_t hetinv_param_map_size(const hetinv_param_map_t *map) {
  HV_API_ENTER();
  return map ? map->cell_count * (size_t)map->free_count : 0;
}

HETINV_API uint32_t hetinv_param_map_free_mask(const hetinv_param_map_t *map) {
  HV_API_ENTER();
  return map ? map->free_mask : 0;
}

HETINV_API hetinv_result_t hetinv_param_map_get_dims(const hetinv_param_map_t *map, int32_t dims[3]) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, map);
  HV_CHECK_NULL(map->ctx, dims);
  memcpy(dims, map->cells, sizeof map->cells);
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_param_map_entry(const hetinv_param_map_t *map, size_t index,
                                                  hetinv_param_t *param, size_t *cell) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, map);
  if (index >= hetinv_param_map_size(map)) {
    return HV_FAIL(map->ctx, HETINV_ERROR_OUT_OF_RANGE, "index %zu is beyond the map's %zu entries",
                   index, hetinv_param_map_size(map));
  }
  if (param) *param = map->free_params[index / map->cell_count];
  if (cell) *cell = index % map->cell_count;
  return HETINV_SUCCESS;
}

/* Calls visit(cell, weight) for the (up to 8) cells voxel (x, y, z) reads. */
#define FOR_EACH_CELL(m, x, y, z, BODY) \
  for (int bz = 0; bz < 2; ++bz) { \
    double wz = bz ? (m)->axis[2].w_hi[z] : 1.0 - (m)->axis[2].w_hi[z]; \
    int32_t cz = bz ? (m)->axis[2].hi[z] : (m)->axis[2].lo[z]; \
    if (wz == 0.0) continue; \
    for (int by = 0; by < 2; ++by) { \
      double wy = by ? (m)->axis[1].w_hi[y] : 1.0 - (m)->axis[1].w_hi[y]; \
      int32_t cy = by ? (m)->axis[1].hi[y] : (m)->axis[1].lo[y]; \
      if (wy == 0.0) continue; \
      for (int bx = 0; bx < 2; ++bx) { \
        double wx = bx ? (m)->axis[0].w_hi[x] : 1.0 - (m)->axis[0].w_hi[x]; \
        int32_t cx = bx ? (m)->axis[0].hi[x] : (m)->axis[0].lo[x]; \
        if (wx == 0.0) continue; \
        size_t cell = (size_t)cx + (size_t)(m)->cells[0] * ((size_t)cy + (size_t)(m)->cells[1] * (size_t)cz); \
        double weight = wx * wy * wz; \
        BODY \
      } \
    } \
  }

bool hv_param_map_fits(const hetinv_param_map_t *map, const hetinv_medium_t *medium) {
  return memcmp(map->fine, medium->dims, sizeof map->fine) == 0;
}

static hetinv_result_t check_grid(const hetinv_param_map_t *map, const hetinv_medium_t *medium) {
  if (!hv_param_map_fits(map, medium)) {
    return HV_FAIL(map->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the medium's grid is %d x %d x %d; the map was made for %d x %d x %d",
                   (int)medium->dims[0], (int)medium->dims[1], (int)medium->dims[2],
                   (int)map->fine[0], (int)map->fine[1], (int)map->fine[2]);
  }
  return HETINV_SUCCESS;
}

static hetinv_result_t check_count(const hetinv_param_map_t *map, size_t count) {
  if (count != hetinv_param_map_size(map)) {
    return HV_FAIL(map->ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "count is %zu; the map has %zu entries", count, hetinv_param_map_size(map));
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_param_map_apply(const hetinv_param_map_t *map, const double *pi,
                                                  size_t count, hetinv_medium_t *medium) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, map);
  HV_CHECK_NULL(map->ctx, pi);
  HV_CHECK_NULL(map->ctx, medium);
  hetinv_result_t r = check_count(map, count);
  if (r == HETINV_SUCCESS) r = check_grid(map, medium);
  if (r != HETINV_SUCCESS) return r;
  if (medium->committed) {
    return HV_FAIL(map->ctx, HETINV_ERROR_INVALID_STATE, "the medium is committed; apply to a clone");
  }
  /* Validate everything first so that a failure changes nothing. */
  for (int pass = 0; pass < 2; ++pass) {
    for (int32_t f = 0; f < map->free_count; ++f) {
      hetinv_param_t p = map->free_params[f];
      const double *block = pi + (size_t)f * map->cell_count;
      size_t k = 0;
      for (int32_t z = 0; z < map->fine[2]; ++z) {
        for (int32_t y = 0; y < map->fine[1]; ++y) {
          for (int32_t x = 0; x < map->fine[0]; ++x, ++k) {
            double v = 0.0;
            FOR_EACH_CELL(map, x, y, z, { v += weight * block[cell]; })
            if (pass == 0) {
              r = hv_medium_check_voxel_value(medium, p, k, v);
              if (r != HETINV_SUCCESS) return r;
            } else {
              medium->values[p][k] = v;
            }
          }
        }
      }
    }
  }
  return HETINV_SUCCESS;
}

/* out[cell] = Σ_voxels weight·in[voxel] over each free block; with
 * `normalise`, divided by Σ weight (an average). False if out of memory. */
static bool pull(const hetinv_param_map_t *map, const double *const in[HETINV_PARAM_COUNT],
                 double *out, bool normalise) {
  if (map->cell_count == map->voxel_count) { /* identity: each cell is its voxel */
    for (int32_t f = 0; f < map->free_count; ++f) {
      memcpy(out + (size_t)f * map->cell_count, in[map->free_params[f]], map->cell_count * sizeof(double));
    }
    return true;
  }
  memset(out, 0, hetinv_param_map_size(map) * sizeof(double));
  for (int32_t f = 0; f < map->free_count; ++f) {
    const double *src = in[map->free_params[f]];
    double *block = out + (size_t)f * map->cell_count;
    size_t k = 0;
    for (int32_t z = 0; z < map->fine[2]; ++z) {
      for (int32_t y = 0; y < map->fine[1]; ++y) {
        for (int32_t x = 0; x < map->fine[0]; ++x, ++k) {
          FOR_EACH_CELL(map, x, y, z, { block[cell] += weight * src[k]; })
        }
      }
    }
  }
  if (!normalise) return true;
  /* Σ weight per cell: the same pull of a field of ones. */
  double *wsum = hv_calloc(map->ctx, map->cell_count, sizeof(double));
  if (wsum == NULL) return false;
  for (int32_t z = 0; z < map->fine[2]; ++z) {
    for (int32_t y = 0; y < map->fine[1]; ++y) {
      for (int32_t x = 0; x < map->fine[0]; ++x) {
        FOR_EACH_CELL(map, x, y, z, { wsum[cell] += weight; })
      }
    }
  }
  for (int32_t f = 0; f < map->free_count; ++f) {
    double *block = out + (size_t)f * map->cell_count;
    for (size_t c = 0; c < map->cell_count; ++c) block[c] = wsum[c] > 0.0 ? block[c] / wsum[c] : 0.0;
  }
  hv_free(map->ctx, wsum);
  return true;
}

HETINV_API hetinv_result_t hetinv_param_map_extract(const hetinv_param_map_t *map,
                                                    const hetinv_medium_t *medium, double *pi,
                                                    size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, map);
  HV_CHECK_NULL(map->ctx, medium);
  HV_CHECK_NULL(map->ctx, pi);
  hetinv_result_t r = check_count(map, count);
  if (r == HETINV_SUCCESS) r = check_grid(map, medium);
  if (r != HETINV_SUCCESS) return r;
  const double *in[HETINV_PARAM_COUNT] = {medium->values[0], medium->values[1], medium->values[2]};
  if (!pull(map, in, pi, true)) return HV_FAIL(map->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate");
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_param_map_pullback(const hetinv_param_map_t *map,
                                                     const double *voxel_grad, double *pi_grad,
                                                     size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, map);
  HV_CHECK_NULL(map->ctx, voxel_grad);
  HV_CHECK_NULL(map->ctx, pi_grad);
  hetinv_result_t r = check_count(map, count);
  if (r != HETINV_SUCCESS) return r;
  const double *in[HETINV_PARAM_COUNT] = {voxel_grad, voxel_grad + map->voxel_count,
                                          voxel_grad + 2 * map->voxel_count};
  (void)pull(map, in, pi_grad, false); /* allocates nothing without normalise */
  return HETINV_SUCCESS;
}

void hv_param_map_pushforward(const hetinv_param_map_t *map, const double *pi, int32_t tangents,
                              double *voxel) {
  size_t T = (size_t)tangents, K = hetinv_param_map_size(map), V = map->voxel_count;
  memset(voxel, 0, 3 * V * T * sizeof(double));
  for (int32_t f = 0; f < map->free_count; ++f) {
    hetinv_param_t p = map->free_params[f];
    size_t k = 0;
    for (int32_t z = 0; z < map->fine[2]; ++z) {
      for (int32_t y = 0; y < map->fine[1]; ++y) {
        for (int32_t x = 0; x < map->fine[0]; ++x, ++k) {
          double *out = voxel + ((size_t)p * V + k) * T;
          FOR_EACH_CELL(map, x, y, z, {
            size_t i = (size_t)f * map->cell_count + cell;
            for (size_t t = 0; t < T; ++t) out[t] += weight * pi[t * K + i];
          })
        }
      }
    }
  }
}
