/* The per-voxel arrays of a pass's grid and of its per-thread copies,
 * kept by the estimator between passes. A grid of 10^6 voxels has 33 MB of
 * them per copy. Allocated afresh, the heap may hand back pages the kernel
 * must map again, one fault at a time, and two threads' faults contend:
 * A1-het's two-thread render of 300 000 photons took 0.42-0.59 s so, and
 * 0.28-0.32 s with the arrays kept (docs/results/kernel.md). Kept, a pass
 * on a grid of the same size writes its values into mapped pages. */
#ifndef HV_GRID_STORE_H
#define HV_GRID_STORE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"

struct hv_voxel;

/* One grid's arrays: its voxel records and, once a delta-tracked grid
 * needed them, its acceptance bytes. */
typedef struct hv_grid_slot {
  struct hv_voxel *voxel;
  uint8_t *sigma_t_q; /* NULL until asked for */
} hv_grid_slot_t;

typedef struct hv_grid_store {
  size_t voxels;         /* each slot's arrays hold this many voxels */
  int count;             /* slots held: 0 is the grid's, i ≥ 1 thread i's copy */
  hv_grid_slot_t *slot;
} hv_grid_store_t;

/* Slot i of s for a grid of `voxels` voxels, with acceptance bytes if
 * `bytes`: what s holds when the size matches (every slot is dropped when
 * it does not), else allocated. NULL if memory ran out; s stays valid. The
 * arrays' contents are whatever the last pass left: the caller writes
 * every entry it reads. */
hv_grid_slot_t *hv_grid_store_slot(const hetinv_context_t *ctx, hv_grid_store_t *s, int i, size_t voxels,
                                   bool bytes);

/* Frees every slot and empties s. */
void hv_grid_store_release(const hetinv_context_t *ctx, hv_grid_store_t *s);

#endif
