#include "transport/grid_store.h"

#include <string.h>

#include "core/alloc.h"
#include "transport/grid.h"

void hv_grid_store_release(const hetinv_context_t *ctx, hv_grid_store_t *s) {
  for (int i = 0; i < s->count; ++i) {
    hv_free(ctx, s->slot[i].voxel);
    hv_free(ctx, s->slot[i].sigma_t_q);
  }
  hv_free(ctx, s->slot);
  memset(s, 0, sizeof *s);
}

hv_grid_slot_t *hv_grid_store_slot(const hetinv_context_t *ctx, hv_grid_store_t *s, int i, size_t voxels,
                                   bool bytes) {
  if (s->voxels != voxels) hv_grid_store_release(ctx, s);
  if (i >= s->count) {
    hv_grid_slot_t *grown = hv_alloc(ctx, (size_t)(i + 1) * sizeof *grown);
    if (grown == NULL) return NULL;
    if (s->count > 0) memcpy(grown, s->slot, (size_t)s->count * sizeof *grown);
    memset(grown + s->count, 0, (size_t)(i + 1 - s->count) * sizeof *grown);
    hv_free(ctx, s->slot);
    s->slot = grown;
    s->count = i + 1;
    s->voxels = voxels;
  }
  hv_grid_slot_t *slot = &s->slot[i];
  size_t record_bytes = 0;
  if (slot->voxel == NULL && hv_mul_size(voxels, sizeof *slot->voxel, &record_bytes)) {
    slot->voxel = hv_alloc(ctx, record_bytes);
  }
  if (bytes && slot->sigma_t_q == NULL) slot->sigma_t_q = hv_alloc(ctx, voxels);
  return slot->voxel != NULL && (!bytes || slot->sigma_t_q != NULL) ? slot : NULL;
}
