#include "estimator/grad_scratch.h"

#include <string.h>

#include "core/alloc.h"

/* Each per-thread array is apart from its neighbours (hv_calloc_apart). */
static bool alloc_tally(const hetinv_context_t *ctx, size_t voxels, hv_grad_tally_t *gt) {
  memset(gt, 0, sizeof *gt);
  gt->voxels = voxels;
  gt->grad = hv_calloc_apart(ctx, 3 * voxels, sizeof(double));
  gt->touched = hv_calloc_apart(ctx, voxels, 1);
  gt->touched_list = hv_calloc_apart(ctx, voxels, sizeof(int64_t));
  gt->path.ctx = gt->chain.ctx = ctx;
  return gt->grad && gt->touched && gt->touched_list;
}

static void free_tally(const hetinv_context_t *ctx, hv_grad_tally_t *gt) {
  hv_free(ctx, gt->grad);
  hv_free(ctx, gt->touched);
  hv_free(ctx, gt->touched_list);
  hv_grad_tally_release_logs(gt);
  memset(gt, 0, sizeof *gt);
}

void hv_grad_scratch_release(const hetinv_context_t *ctx, hv_grad_scratch_t *s) {
  for (int t = 0; s->grads && t < s->slots; ++t) free_tally(ctx, &s->grads[t]);
  hv_free(ctx, s->grads);
  free_tally(ctx, &s->emitter);
  hv_free(ctx, s->total);
  memset(s, 0, sizeof *s);
}

bool hv_grad_scratch_take(const hetinv_context_t *ctx, hv_grad_scratch_t *s, size_t voxels, int slots) {
  if (s->voxels == voxels && s->slots == slots && voxels > 0) return true;
  hv_grad_scratch_release(ctx, s);
  s->grads = hv_calloc(ctx, (size_t)slots, sizeof *s->grads);
  s->slots = s->grads ? slots : 0;
  bool ok = s->grads != NULL && alloc_tally(ctx, voxels, &s->emitter);
  s->total = ok ? hv_calloc(ctx, 3 * voxels, sizeof(double)) : NULL;
  ok = ok && s->total != NULL;
  for (int t = 0; ok && t < slots; ++t) ok = alloc_tally(ctx, voxels, &s->grads[t]);
  if (!ok) {
    hv_grad_scratch_release(ctx, s);
    return false;
  }
  s->voxels = voxels;
  return true;
}
