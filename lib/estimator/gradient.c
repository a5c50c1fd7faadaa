/* The gradient pass (Eqs. 20–22): vector–Jacobian products of the rendered
 * values by score-function estimation, and the appearance-matching loss. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/comm.h"
#include "core/error.h"
#include "core/hash.h"
#include "estimator/batches.h"
#include "estimator/gain.h"
#include "estimator/grad_scratch.h"
#include "estimator/loss_term.h"
#include "estimator/pass.h"
#include "estimator/record.h"
#include "estimator/set_hash.h"
#include "hetinv/param.h"
#include "param/param_map_internal.h"
#include "medium/medium_internal.h"
#include "sampling/measurements_internal.h"

/* Reduction order, the same for any thread count and any rank count:
 * items run emitter-major over this rank's emitters (item = (e - lo)·B + b);
 * an emitter's batches are summed in batch order into its own partial
 * gradient (voxel space, with its touched voxels); each finished emitter's
 * partial becomes a record (the touched voxels and their three entries,
 * and for standard errors its squared standard error per π entry), and the
 * records are added to the totals in emitter order. One rank adds each
 * record as soon as it is made; several ranks gather every rank's records
 * (rank blocks are contiguous, so the concatenation is in emitter order)
 * and every rank adds them all: the same additions in the same order. */
typedef struct gradient {
  const hv_pass_t *pass;
  const hetinv_param_map_t *map;
  size_t voxels, k;        /* voxel count; length of π */
  hv_tally_t *tallies;      /* one per tally slot (batches.h) */
  /* The estimator's scratch (grad_scratch.h), which the pass leaves zeroed: */
  hv_grad_tally_t *grads;   /* one per tally slot (batches.h) */
  hv_grad_tally_t *emitter; /* the current emitter's partial gradient */
  double *total;            /* Σ over emitters, per voxel entry (3 blocks) */
  /* For standard errors only: the current emitter's batch means pulled
   * back to π (the current one, their sum and sum of squares), and per π
   * entry the sum over finished emitters of their squared errors. */
  double *pi_batch, *mean_sum, *mean_sq, *var;
  hv_record_t records; /* finished emitters not yet added */
  bool out_of_memory;
} gradient_t;

static void run_item(void *self, int64_t item, int slot) {
  gradient_t *g = self;
  const hv_pass_t *pass = g->pass;
  hv_pass_trace_batch(pass, pass->emitter_lo + (int32_t)(item / pass->batches),
                      (int32_t)(item % pass->batches), &g->tallies[slot]);
  hv_grad_tally_t *gt = &g->grads[slot];
  if (gt->path.out_of_memory || gt->chain.out_of_memory) g->out_of_memory = true;
}

/* Moves the touched entries of `from` into `to`, resetting them. */
static void drain(const gradient_t *g, hv_grad_tally_t *from, hv_grad_tally_t *to) {
  for (size_t i = 0; i < from->touched_count; ++i) {
    int64_t v = from->touched_list[i];
    for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
      double *x = &from->grad[(size_t)p * g->voxels + (size_t)v];
      hv_grad_add(to, p, v, *x);
      *x = 0.0;
    }
    from->touched[v] = 0;
  }
  from->touched_count = 0;
}

/* Adds records (as made by finish_emitter) to the totals, in their order. */
static void add_records(gradient_t *g, const double *rec, size_t count) {
  size_t at = 0, v3 = g->voxels;
  while (at < count) {
    size_t touched = (size_t)rec[at++];
    for (size_t i = 0; i < touched; ++i, at += 4) {
      size_t v = (size_t)rec[at];
      g->total[v] += rec[at + 1];
      g->total[v3 + v] += rec[at + 2];
      g->total[2 * v3 + v] += rec[at + 3];
    }
    if (g->var == NULL) continue;
    size_t nonzero = (size_t)rec[at++];
    for (size_t i = 0; i < nonzero; ++i, at += 2) g->var[(size_t)rec[at]] += rec[at + 1];
  }
}

/* Checks that records hold whole emitters' records, `emitters` of them. */
static bool records_well_formed(const gradient_t *g, const double *rec, size_t count,
                                int32_t emitters) {
  size_t at = 0;
  for (int32_t e = 0; e < emitters; ++e) {
    if (at >= count || !(rec[at] >= 0.0 && rec[at] <= (double)g->voxels)) return false;
    size_t touched = (size_t)rec[at++];
    if ((count - at) / 4 < touched) return false;
    for (size_t i = 0; i < touched; ++i, at += 4) {
      if (!(rec[at] >= 0.0 && rec[at] < (double)g->voxels)) return false;
    }
    if (g->var == NULL) continue;
    if (at >= count || !(rec[at] >= 0.0 && rec[at] <= (double)g->k)) return false;
    size_t nonzero = (size_t)rec[at++];
    if ((count - at) / 2 < nonzero) return false;
    for (size_t i = 0; i < nonzero; ++i, at += 2) {
      if (!(rec[at] >= 0.0 && rec[at] < (double)g->k)) return false;
    }
  }
  return at == count;
}

/* The current emitter is complete: its record joins `records` and its
 * accumulators are reset. One rank adds the record at once. */
static void finish_emitter(gradient_t *g) {
  hv_grad_tally_t *em = g->emitter;
  hv_record_t *rec = &g->records;
  if (hv_record_reserve(rec, 1 + 4 * em->touched_count)) {
    hv_record_put(rec, (double)em->touched_count);
    for (size_t i = 0; i < em->touched_count; ++i) {
      size_t v = (size_t)em->touched_list[i];
      hv_record_put(rec, (double)v);
      for (int p = 0; p < HETINV_PARAM_COUNT; ++p) hv_record_put(rec, em->grad[(size_t)p * g->voxels + v]);
    }
  }
  for (size_t i = 0; i < em->touched_count; ++i) {
    size_t v = (size_t)em->touched_list[i];
    for (int p = 0; p < HETINV_PARAM_COUNT; ++p) em->grad[(size_t)p * g->voxels + v] = 0.0;
    em->touched[v] = 0;
  }
  em->touched_count = 0;
  if (g->var != NULL) {
    /* Emitters trace independent photons: the variance of the total is
     * the sum of the emitters' variances. */
    int32_t batches = g->pass->batches;
    size_t nonzero = 0;
    for (size_t i = 0; i < g->k; ++i) {
      double se = hv_batch_std_error(g->mean_sum[i], g->mean_sq[i], batches);
      g->mean_sum[i] = se * se; /* reused: the emitter's variance */
      nonzero += g->mean_sum[i] != 0.0;
    }
    if (hv_record_reserve(rec, 1 + 2 * nonzero)) {
      hv_record_put(rec, (double)nonzero);
      for (size_t i = 0; i < g->k; ++i) {
        if (g->mean_sum[i] == 0.0) continue; /* adding +0 to a sum of squares changes nothing */
        hv_record_put(rec, (double)i);
        hv_record_put(rec, g->mean_sum[i]);
      }
    }
    memset(g->mean_sum, 0, g->k * sizeof(double));
    memset(g->mean_sq, 0, g->k * sizeof(double));
  }
  if (rec->out_of_memory) g->out_of_memory = true;
  if (g->pass->ranks == 1 && !rec->out_of_memory) {
    add_records(g, rec->data, rec->count);
    rec->count = 0;
  }
}

static void reduce_item(void *self, int64_t item, int slot) {
  gradient_t *g = self;
  const hv_pass_t *pass = g->pass;
  hv_grad_tally_t *gt = &g->grads[slot];
  int32_t b = (int32_t)(item % pass->batches);
  hv_grad_fold_extinction(gt); /* σs is complete from here on */
  if (g->var != NULL) {
    /* This batch's mean, in π space, enters its emitter's error. */
    double n = hv_pass_batch_size(pass, b);
    hetinv_param_map_pullback(g->map, gt->grad, g->pi_batch, g->k);
    for (size_t i = 0; i < g->k; ++i) {
      double m = g->pi_batch[i] / n;
      g->mean_sum[i] += m;
      g->mean_sq[i] += m * m;
    }
  }
  drain(g, gt, g->emitter);
  if (b + 1 == pass->batches) finish_emitter(g);
}

/* A pass that failed part-way leaves scratch entries set: it is dropped. */
static void release(const hetinv_context_t *ctx, gradient_t *g, hv_grad_scratch_t *scratch, bool failed) {
  if (failed) hv_grad_scratch_release(ctx, scratch);
  hv_free(ctx, g->tallies);
  hv_free(ctx, g->pi_batch);
  hv_free(ctx, g->mean_sum);
  hv_free(ctx, g->mean_sq);
  hv_free(ctx, g->var);
  hv_record_release(&g->records);
}

/* Several ranks: every rank's records, in emitter order, added on every
 * rank. Collective: a rank that failed takes part with its code. */
static hetinv_result_t share(gradient_t *g, hetinv_result_t status) {
  const hetinv_context_t *ctx = g->pass->ctx;
  double *all = NULL;
  size_t all_count = 0;
  hetinv_result_t r = hv_comm_allgather(ctx, g->records.data, g->records.count, status, &all,
                                        &all_count);
  if (r == HETINV_SUCCESS && !records_well_formed(g, all, all_count, g->pass->plans.count)) {
    r = HV_FAIL(ctx, HETINV_ERROR_INTERNAL,
                "the ranks' partial gradients (%zu doubles) are not %d emitters' records", all_count,
                (int)g->pass->plans.count);
  }
  if (r == HETINV_SUCCESS) add_records(g, all, all_count);
  hv_free(ctx, all);
  return r;
}

hetinv_result_t hv_gradient_run(const hv_pass_t *pass, const hetinv_param_map_t *map,
                                const double *cotangent, double *grad, double *grad_se) {
  const hetinv_context_t *ctx = pass->ctx;
  gradient_t g = {.pass = pass, .map = map, .k = hetinv_param_map_size(map)};
  g.records.ctx = ctx;
  g.voxels = (size_t)pass->grid.n[0] * (size_t)pass->grid.n[1] * (size_t)pass->grid.n[2];
  /* Per slot: 3 doubles, a byte and an index per voxel (hv_grad_tally_t). */
  int threads, slots = hv_pass_slot_count(pass, g.voxels * (3 * sizeof(double) + 1 + sizeof(int64_t)),
                                          &threads);
  hv_grad_scratch_t *scratch = pass->grad_scratch;
  g.tallies = hv_calloc(ctx, (size_t)slots, sizeof *g.tallies);
  bool ok = g.tallies && hv_grad_scratch_take(ctx, scratch, g.voxels, slots);
  if (ok) {
    g.grads = scratch->grads;
    g.emitter = &scratch->emitter;
    g.total = scratch->total;
    memset(g.total, 0, 3 * g.voxels * sizeof(double));
  }
  if (ok && grad_se) {
    g.pi_batch = hv_calloc(ctx, g.k, sizeof(double));
    g.mean_sum = hv_calloc(ctx, g.k, sizeof(double));
    g.mean_sq = hv_calloc(ctx, g.k, sizeof(double));
    g.var = hv_calloc(ctx, g.k, sizeof(double));
    ok = g.pi_batch && g.mean_sum && g.mean_sq && g.var;
  }
  for (int t = 0; ok && t < slots; ++t) {
    g.grads[t].cotangent = cotangent;
    g.tallies[t].grad = &g.grads[t];
  }
  if (ok) {
    hv_batch_loop_t loop = {(int64_t)(pass->emitter_hi - pass->emitter_lo) * pass->batches,
                            threads, &g, run_item, reduce_item, slots};
    hv_batches_run(&loop);
    ok = !g.out_of_memory;
  }
  hetinv_result_t r = HETINV_SUCCESS;
  if (!ok) r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the gradient buffers");
  if (pass->ranks > 1) r = share(&g, r);
  if (r == HETINV_SUCCESS) {
    hetinv_param_map_pullback(map, g.total, grad, g.k);
    double n = (double)pass->photons;
    for (size_t i = 0; i < g.k; ++i) {
      grad[i] /= n;
      if (grad_se) grad_se[i] = sqrt(g.var[i]);
    }
  }
  release(ctx, &g, scratch, r != HETINV_SUCCESS);
  return r;
}

/* Checks the map against the medium and the output. */
static hetinv_result_t check_map(const hetinv_context_t *ctx, const hetinv_param_map_t *map,
                                 const hetinv_medium_t *medium, const double *grad,
                                 size_t grad_count) {
  if (map == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'map' is NULL");
  if (grad == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'grad' is NULL");
  if (!hv_param_map_fits(map, medium)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the parameter map was made for another grid than the medium's %d x %d x %d",
                   (int)medium->dims[0], (int)medium->dims[1], (int)medium->dims[2]);
  }
  if (grad_count != hetinv_param_map_size(map)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "grad_count is %zu; the map has %zu entries", grad_count,
                   hetinv_param_map_size(map));
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_estimator_gradient(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *cotangent, size_t count, const hetinv_param_map_t *map, double *grad,
    double *grad_std_errors, size_t grad_count) {
  HV_API_ENTER();
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, count, &pass);
  if (r == HETINV_SUCCESS) r = check_map(pass.ctx, map, medium, grad, grad_count);
  if (r == HETINV_SUCCESS && cotangent == NULL) r = HV_FAIL(pass.ctx, HETINV_ERROR_NULL_ARGUMENT, "'cotangent' is NULL");
  for (size_t i = 0; r == HETINV_SUCCESS && i < count; ++i) {
    if (!isfinite(cotangent[i])) {
      r = HV_FAIL(pass.ctx, HETINV_ERROR_INVALID_ARGUMENT, "cotangent[%zu] is %g; it must be finite",
                  i, cotangent[i]);
    }
  }
  /* The ranks' key: a gradient, its cotangent, its size, and whether the
   * records hold the batch means (standard errors). */
  uint64_t call = UINT64_C(0x47524144) + (grad_std_errors != NULL);
  if (r == HETINV_SUCCESS && pass.ranks > 1) {
    call = hv_fnv1a(call, &grad_count, sizeof grad_count);
    call = hv_fnv1a_doubles(call, cotangent, count);
  }
  r = hv_pass_agree(estimator, medium, set, r, call);
  if (r == HETINV_SUCCESS) r = hv_gradient_run(&pass, map, cotangent, grad, grad_std_errors);
  hv_pass_end(&pass);
  return r;
}

HETINV_API hetinv_result_t hetinv_estimator_loss_gradient(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const hetinv_param_map_t *map, double *loss, double *rendered, double *grad, size_t grad_count) {
  HV_API_ENTER();
  if (estimator) estimator->gain_count = 0; /* a failed call leaves no stale gains */
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, set ? set->value_count : 0, &pass);
  const hetinv_context_t *ctx = pass.ctx;
  if (r == HETINV_SUCCESS) r = check_map(ctx, map, medium, grad, grad_count);
  size_t n = r == HETINV_SUCCESS ? set->value_count : 0;
  double *values = r == HETINV_SUCCESS ? hv_calloc(ctx, n, sizeof(double)) : NULL;
  double *cot = r == HETINV_SUCCESS ? hv_calloc(ctx, n, sizeof(double)) : NULL;
  /* With a gain: the render's standard errors, for the gain's denominator. */
  const bool gain = r == HETINV_SUCCESS && estimator->gain_mode != HETINV_GAIN_NONE;
  double *se = gain ? hv_calloc(ctx, n, sizeof(double)) : NULL;
  if (r == HETINV_SUCCESS && (values == NULL || cot == NULL || (gain && se == NULL))) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu values", n);
  }
  /* The ranks' key: a loss gradient, its size, and the measured values. */
  uint64_t call = UINT64_C(0x4c4f5353);
  if (r == HETINV_SUCCESS && pass.ranks > 1) {
    uint64_t values_hash = hv_set_values_hash(set);
    call = hv_fnv1a(call, &grad_count, sizeof grad_count);
    call = hv_fnv1a(call, &values_hash, sizeof values_hash);
  }
  r = hv_pass_agree(estimator, medium, set, r, call);
  if (r == HETINV_SUCCESS) {
    /* I from stream s; the gradient from the independent stream s + 1. */
    r = hv_forward_run(estimator, &pass, values, se, NULL, n);
    double sum = 0.0;
    if (r == HETINV_SUCCESS && gain) {
      r = hv_gain_fit(estimator, &pass, set, values, se, cot, &sum);
      r = hv_comm_agree(ctx, r, 0, "nothing"); /* the fit's allocation may fail on one rank */
    } else if (r == HETINV_SUCCESS) {
      const double clip = estimator->param[HETINV_ESTIMATOR_LOSS_CLIP];
      for (size_t i = 0; i < n; ++i) {
        double w = set->mask[i] ? set->weights[i] : 0.0;
        sum += hv_loss_term(w, values[i] - set->values[i], clip, set->clip_below[i], set->clip_above[i], &cot[i]);
      }
    }
    if (r == HETINV_SUCCESS) {
      if (loss) *loss = sum;
      if (rendered) memcpy(rendered, values, n * sizeof(double));
      pass.stream = (pass.stream + 1) % HV_RNG_STREAM_LIMIT;
      r = hv_gradient_run(&pass, map, cot, grad, NULL);
    }
  }
  hv_free(ctx, values);
  hv_free(ctx, cot);
  hv_free(ctx, se);
  hv_pass_end(&pass);
  if (r != HETINV_SUCCESS && estimator != NULL) estimator->gain_count = 0;
  return r;
}
