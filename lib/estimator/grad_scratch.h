/* The gradient pass's voxel-sized scratch, kept by the estimator between
 * passes: per tally slot three gradient blocks, a touched byte and an
 * index per voxel (hv_grad_tally_t), the current emitter's partial, and
 * the pass's total. A pass leaves the slots and the partial zeroed (it
 * resets exactly the entries it touched), so the next pass on a grid of
 * the same size starts on warm pages. Allocating and first touching them
 * in every pass cost about a tenth of a gradient pass on A1's 10^6
 * voxels, in the kernel's page-fault path, which two threads also
 * contend for (docs/results/kernel.md). */
#ifndef HV_GRAD_SCRATCH_H
#define HV_GRAD_SCRATCH_H

#include <stdbool.h>
#include <stddef.h>

#include "transport/tracer.h"

typedef struct hv_grad_scratch {
  size_t voxels; /* the grid size the arrays were made for; 0: none yet */
  int slots;
  hv_grad_tally_t *grads;  /* `slots` of them, zeroed */
  hv_grad_tally_t emitter; /* zeroed */
  double *total;           /* 3 blocks of `voxels`; zeroed by each pass */
} hv_grad_scratch_t;

/* Makes s hold `slots` zeroed slots for `voxels` voxels, reusing what it
 * holds when both match; false (s emptied) if memory ran out. */
bool hv_grad_scratch_take(const hetinv_context_t *ctx, hv_grad_scratch_t *s, size_t voxels, int slots);

/* Frees what s holds and empties it; a pass that failed part-way leaves
 * entries set, so it calls this. */
void hv_grad_scratch_release(const hetinv_context_t *ctx, hv_grad_scratch_t *s);

#endif
