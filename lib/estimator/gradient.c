/* The gradient pass (Eqs. 20–22): vector–Jacobian products of the rendered
 * values by score-function estimation, and the appearance-matching loss. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "estimator/batches.h"
#include "estimator/pass.h"
#include "hetinv/param.h"
#include "optimize/param_map_internal.h"
#include "medium/medium_internal.h"
#include "sampling/measurements_internal.h"

typedef struct gradient {
  const hv_pass_t *pass;
  const hetinv_param_map_t *map;
  size_t voxels, k;        /* voxel count; length of π */
  hv_tally_t *tallies;     /* one per thread */
  hv_grad_tally_t *grads;  /* one per thread */
  double *total;           /* Σ of every item, per voxel entry (3 blocks) */
  /* For standard errors only: the current batch summed over emitters (per
   * voxel entry, with its touched voxels), and per π entry the sum and sum
   * of squares of batch means. */
  hv_grad_tally_t batch;
  double *pi_batch, *mean_sum, *mean_sq;
  bool out_of_memory;
} gradient_t;

/* Items run batch-major (item = b·E + e), so that the gradients of one batch
 * of every emitter are summed before the batch's mean enters the error. */
static void run_item(void *self, int64_t item, int thread) {
  gradient_t *g = self;
  int32_t emitters = g->pass->plans.count;
  hv_pass_trace_batch(g->pass, (int32_t)(item % emitters), (int32_t)(item / emitters),
                      &g->tallies[thread]);
  hv_grad_tally_t *gt = &g->grads[thread];
  if (gt->path.out_of_memory || gt->chain.out_of_memory) g->out_of_memory = true;
}

/* Moves the touched entries of `from` into `total` (and `batch`), resetting them. */
static void drain(const gradient_t *g, hv_grad_tally_t *from, double *total, hv_grad_tally_t *batch) {
  for (size_t i = 0; i < from->touched_count; ++i) {
    int64_t v = from->touched_list[i];
    for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
      double *x = &from->grad[(size_t)p * g->voxels + (size_t)v];
      total[(size_t)p * g->voxels + (size_t)v] += *x;
      if (batch) hv_grad_add(batch, p, v, *x);
      *x = 0.0;
    }
    from->touched[v] = 0;
  }
  from->touched_count = 0;
}

static void reduce_item(void *self, int64_t item, int thread) {
  gradient_t *g = self;
  const hv_pass_t *pass = g->pass;
  bool with_errors = g->pi_batch != NULL;
  drain(g, &g->grads[thread], g->total, with_errors ? &g->batch : NULL);
  int32_t emitters = pass->plans.count;
  if (!with_errors || (item % emitters) + 1 < emitters) return;
  /* Batch complete: its mean in π space enters the error estimate. */
  double n = hv_pass_batch_size(pass, (int32_t)(item / emitters));
  hetinv_param_map_pullback(g->map, g->batch.grad, g->pi_batch, g->k);
  for (size_t i = 0; i < g->k; ++i) {
    double m = g->pi_batch[i] / n;
    g->mean_sum[i] += m;
    g->mean_sq[i] += m * m;
  }
  for (size_t i = 0; i < g->batch.touched_count; ++i) {
    int64_t v = g->batch.touched_list[i];
    for (int p = 0; p < HETINV_PARAM_COUNT; ++p) g->batch.grad[(size_t)p * g->voxels + (size_t)v] = 0.0;
    g->batch.touched[v] = 0;
  }
  g->batch.touched_count = 0;
}

static bool alloc_grad_tally(const hetinv_context_t *ctx, size_t voxels, hv_grad_tally_t *gt) {
  gt->voxels = voxels;
  gt->grad = hv_calloc(ctx, 3 * voxels, sizeof(double));
  gt->touched = hv_calloc(ctx, voxels, 1);
  gt->touched_list = hv_calloc(ctx, voxels, sizeof(int64_t));
  gt->path.ctx = gt->chain.ctx = ctx;
  return gt->grad && gt->touched && gt->touched_list;
}

static void free_grad_tally(const hetinv_context_t *ctx, hv_grad_tally_t *gt) {
  hv_free(ctx, gt->grad);
  hv_free(ctx, gt->touched);
  hv_free(ctx, gt->touched_list);
  hv_path_log_release(&gt->path);
  hv_path_log_release(&gt->chain);
}

static void release(const hetinv_context_t *ctx, gradient_t *g, int threads) {
  for (int t = 0; g->grads && t < threads; ++t) free_grad_tally(ctx, &g->grads[t]);
  free_grad_tally(ctx, &g->batch);
  hv_free(ctx, g->tallies);
  hv_free(ctx, g->grads);
  hv_free(ctx, g->total);
  hv_free(ctx, g->pi_batch);
  hv_free(ctx, g->mean_sum);
  hv_free(ctx, g->mean_sq);
}

/* The gradient pass proper, on a pass already begun. */
static hetinv_result_t run_gradient(const hv_pass_t *pass, const hetinv_param_map_t *map,
                                    const double *cotangent, double *grad, double *grad_se,
                                    const char *func) {
  const hetinv_context_t *ctx = pass->ctx;
  gradient_t g = {.pass = pass, .map = map, .k = hetinv_param_map_size(map)};
  g.voxels = (size_t)pass->grid.n[0] * (size_t)pass->grid.n[1] * (size_t)pass->grid.n[2];
  int threads = pass->threads;
  g.tallies = hv_calloc(ctx, (size_t)threads, sizeof *g.tallies);
  g.grads = hv_calloc(ctx, (size_t)threads, sizeof *g.grads);
  g.total = hv_calloc(ctx, 3 * g.voxels, sizeof(double));
  bool ok = g.tallies && g.grads && g.total;
  if (ok && grad_se) {
    g.pi_batch = hv_calloc(ctx, g.k, sizeof(double));
    g.mean_sum = hv_calloc(ctx, g.k, sizeof(double));
    g.mean_sq = hv_calloc(ctx, g.k, sizeof(double));
    ok = g.pi_batch && g.mean_sum && g.mean_sq && alloc_grad_tally(ctx, g.voxels, &g.batch);
  }
  for (int t = 0; ok && t < threads; ++t) {
    ok = alloc_grad_tally(ctx, g.voxels, &g.grads[t]);
    g.grads[t].cotangent = cotangent;
    g.tallies[t].grad = &g.grads[t];
  }
  if (ok) {
    hv_batch_loop_t loop = {(int64_t)pass->plans.count * pass->batches, threads, &g, run_item,
                            reduce_item};
    hv_batches_run(&loop);
    ok = !g.out_of_memory;
  }
  if (ok) {
    hetinv_param_map_pullback(map, g.total, grad, g.k);
    double n = (double)pass->photons;
    for (size_t i = 0; i < g.k; ++i) {
      grad[i] /= n;
      if (grad_se) grad_se[i] = hv_batch_std_error(g.mean_sum[i], g.mean_sq[i], pass->batches);
    }
  }
  release(ctx, &g, threads);
  if (!ok) return hv_fail(ctx, HETINV_ERROR_OUT_OF_MEMORY, func, "cannot allocate the gradient buffers");
  return HETINV_SUCCESS;
}

/* Checks the map against the medium and the output. */
static hetinv_result_t check_map(const hetinv_context_t *ctx, const hetinv_param_map_t *map,
                                 const hetinv_medium_t *medium, const double *grad,
                                 size_t grad_count, const char *func) {
  if (map == NULL) return hv_fail(ctx, HETINV_ERROR_NULL_ARGUMENT, func, "'map' is NULL");
  if (grad == NULL) return hv_fail(ctx, HETINV_ERROR_NULL_ARGUMENT, func, "'grad' is NULL");
  if (!hv_param_map_fits(map, medium)) {
    return hv_fail(ctx, HETINV_ERROR_INVALID_ARGUMENT, func,
                   "the parameter map was made for another grid than the medium's %d x %d x %d",
                   (int)medium->dims[0], (int)medium->dims[1], (int)medium->dims[2]);
  }
  if (grad_count != hetinv_param_map_size(map)) {
    return hv_fail(ctx, HETINV_ERROR_INVALID_ARGUMENT, func,
                   "grad_count is %zu; the map has %zu entries", grad_count,
                   hetinv_param_map_size(map));
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_estimator_gradient(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *cotangent, size_t count, const hetinv_param_map_t *map, double *grad,
    double *grad_std_errors, size_t grad_count) {
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, count, __func__, &pass);
  if (r != HETINV_SUCCESS) return r;
  r = check_map(pass.ctx, map, medium, grad, grad_count, __func__);
  if (r == HETINV_SUCCESS && cotangent == NULL) r = HV_FAIL(pass.ctx, HETINV_ERROR_NULL_ARGUMENT, "'cotangent' is NULL");
  for (size_t i = 0; r == HETINV_SUCCESS && i < count; ++i) {
    if (!isfinite(cotangent[i])) {
      r = HV_FAIL(pass.ctx, HETINV_ERROR_INVALID_ARGUMENT, "cotangent[%zu] is %g; it must be finite",
                  i, cotangent[i]);
    }
  }
  if (r == HETINV_SUCCESS) r = run_gradient(&pass, map, cotangent, grad, grad_std_errors, __func__);
  hv_pass_end(&pass);
  return r;
}

HETINV_API hetinv_result_t hetinv_estimator_loss_gradient(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const hetinv_param_map_t *map, double *loss, double *rendered, double *grad, size_t grad_count) {
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, set ? set->value_count : 0, __func__, &pass);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = pass.ctx;
  r = check_map(ctx, map, medium, grad, grad_count, __func__);
  size_t n = set->value_count;
  double *values = r == HETINV_SUCCESS ? hv_calloc(ctx, n, sizeof(double)) : NULL;
  double *cot = r == HETINV_SUCCESS ? hv_calloc(ctx, n, sizeof(double)) : NULL;
  if (r == HETINV_SUCCESS && (values == NULL || cot == NULL)) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu values", n);
  }
  if (r == HETINV_SUCCESS) {
    /* I from stream s; the gradient from the independent stream s + 1. */
    r = hv_forward_run(estimator, &pass, values, NULL, NULL, n, __func__);
    if (r == HETINV_SUCCESS) {
      double sum = 0.0;
      for (size_t i = 0; i < n; ++i) {
        double res = set->mask[i] ? set->weights[i] * (values[i] - set->values[i]) : 0.0;
        sum += res * (values[i] - set->values[i]);
        cot[i] = 2.0 * res;
      }
      if (loss) *loss = sum;
      if (rendered) memcpy(rendered, values, n * sizeof(double));
      pass.stream = (pass.stream + 1) % HV_RNG_STREAM_LIMIT;
      r = run_gradient(&pass, map, cot, grad, NULL, __func__);
    }
  }
  hv_free(ctx, values);
  hv_free(ctx, cot);
  hv_pass_end(&pass);
  return r;
}
