/* The tangent pass: Jacobian–vector products J·v of the rendered values,
 * for T tangents at once, by the score log in tangent mode
 * (transport/path_jvp.h). Reduction as in the forward pass (render.c):
 * items run emitter-major, are reduced in item order, and batch means
 * give each figure's standard error, so the result is bitwise the same
 * for any thread count. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "estimator/batches.h"
#include "estimator/pass.h"
#include "medium/medium_internal.h"
#include "param/param_map_internal.h"
#include "sampling/measurements_internal.h"

typedef struct tangent_pass {
  const hv_pass_t *pass;
  size_t T;
  hv_tally_t *tallies;    /* one per tally slot (batches.h); values: the largest plan's, times T */
  hv_grad_tally_t *grads; /* one per slot: the score logs and running sums */
  double *total;              /* count·T: the caller's output, scaled at the end */
  double *mean_sum, *mean_sq; /* count·T each, only when standard errors are asked */
  /* The tangents' nonzeros by voxel-space row (path_jvp.h), when sparse. */
  size_t *sparse_start;
  int32_t *sparse_index;
  double *sparse_value;
  bool out_of_memory;
} tangent_pass_t;

/* Tallies are compact: a slot holds the values of one plan (emitter) at a
 * time, numbered by hv_row_target_t::local, K doubles each. */
static void run_item(void *self, int64_t item, int slot) {
  tangent_pass_t *f = self;
  hv_tally_t *tally = &f->tallies[slot];
  int32_t e = f->pass->emitter_lo + (int32_t)(item / f->pass->batches);
  const hv_plan_t *plan = &f->pass->plans.plan[e];
  memset(tally->values, 0, plan->value_count * f->T * sizeof(double));
  hv_pass_trace_batch(f->pass, e, (int32_t)(item % f->pass->batches), tally);
  hv_grad_tally_t *gt = &f->grads[slot];
  if (gt->path.out_of_memory || gt->chain.out_of_memory) f->out_of_memory = true;
}

static void reduce_item(void *self, int64_t item, int slot) {
  tangent_pass_t *f = self;
  const hv_tally_t *tally = &f->tallies[slot];
  const hv_pass_t *pass = f->pass;
  int32_t e = pass->emitter_lo + (int32_t)(item / pass->batches);
  const hv_plan_t *plan = &pass->plans.plan[e];
  double n = hv_pass_batch_size(pass, (int32_t)(item % pass->batches));
  for (int32_t i = 0; i < plan->range_count; ++i) { /* one range per row */
    const hv_row_target_t *row = &plan->rows[i];
    size_t end = i + 1 < plan->range_count ? plan->rows[i + 1].local : plan->value_count;
    const double *src = tally->values + row->local * f->T;
    double *total = f->total + row->offset * f->T;
    size_t len = (end - row->local) * f->T, at = row->offset * f->T;
    for (size_t k = 0; k < len; ++k) {
      double x = src[k];
      total[k] += x;
      if (f->mean_sum) {
        double m = x / n;
        f->mean_sum[at + k] += m;
        f->mean_sq[at + k] += m * m;
      }
    }
  }
}

static void release(const hetinv_context_t *ctx, tangent_pass_t *f, int slots) {
  for (int t = 0; t < slots; ++t) {
    if (f->tallies) hv_free(ctx, f->tallies[t].values);
    if (f->grads) {
      hv_free(ctx, f->grads[t].jvp.run);
      hv_grad_tally_release_logs(&f->grads[t]);
    }
  }
  hv_free(ctx, f->tallies);
  hv_free(ctx, f->grads);
  hv_free(ctx, f->mean_sum);
  hv_free(ctx, f->mean_sq);
  hv_free(ctx, f->sparse_start);
  hv_free(ctx, f->sparse_index);
  hv_free(ctx, f->sparse_value);
}

/* The sparse copy of the tangents when at most a quarter of their entries
 * are nonzero (one-hot tangents: one per row); true if none is needed or
 * it was built, false without memory. */
static bool sparsify(const hetinv_context_t *ctx, const double *tangent, size_t rows, size_t T,
                     tangent_pass_t *f) {
  size_t nnz = 0;
  for (size_t i = 0; i < rows * T; ++i) nnz += tangent[i] != 0.0;
  if (nnz > rows * T / 4) return true;
  f->sparse_start = hv_calloc(ctx, rows + 1, sizeof(size_t));
  f->sparse_index = hv_calloc(ctx, nnz ? nnz : 1, sizeof(int32_t));
  f->sparse_value = hv_calloc(ctx, nnz ? nnz : 1, sizeof(double));
  if (!(f->sparse_start && f->sparse_index && f->sparse_value)) return false;
  size_t at = 0;
  for (size_t row = 0; row < rows; ++row) {
    f->sparse_start[row] = at;
    for (size_t t = 0; t < T; ++t) {
      double v = tangent[row * T + t];
      if (v == 0.0) continue;
      f->sparse_index[at] = (int32_t)t;
      f->sparse_value[at++] = v;
    }
  }
  f->sparse_start[rows] = at;
  return true;
}

hetinv_result_t hv_check_pi_map(const hetinv_context_t *ctx, const hetinv_param_map_t *map,
                                const hetinv_medium_t *medium, size_t count, const char *what) {
  if (map == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'map' is NULL");
  if (!hv_param_map_fits(map, medium)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the parameter map was made for another grid than the medium's %d x %d x %d",
                   (int)medium->dims[0], (int)medium->dims[1], (int)medium->dims[2]);
  }
  if (count != hetinv_param_map_size(map)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "%s is %zu; the map has %zu entries",
                   what, count, hetinv_param_map_size(map));
  }
  return HETINV_SUCCESS;
}

hetinv_result_t hv_tangent_run(const hv_pass_t *pass, const double *tangent, int32_t tangents,
                               size_t count, double *values, double *std_errors) {
  const hetinv_context_t *ctx = pass->ctx;
  if (pass->ranks > 1) {
    /* Every rank takes this branch: the same error everywhere, no exchange. */
    return HV_FAIL(ctx, HETINV_ERROR_UNSUPPORTED,
                   "Jacobian-vector products are not distributed over MPI ranks (%d ranks); "
                   "use a context with one rank", (int)pass->ranks);
  }
  size_t voxels = (size_t)pass->grid.n[0] * (size_t)pass->grid.n[1] * (size_t)pass->grid.n[2];
  tangent_pass_t f = {.pass = pass, .T = (size_t)tangents};
  size_t n = 0;
  if (!hv_mul_size(count, f.T, &n)) {
    return HV_FAIL(ctx, HETINV_ERROR_SIZE_OVERFLOW, "%zu values times %d tangents overflow",
                   count, (int)tangents);
  }
  size_t largest = 0, slot_values = 0; /* the largest plan's values, times T */
  for (int32_t e = pass->emitter_lo; e < pass->emitter_hi; ++e) {
    if (pass->plans.plan[e].value_count > largest) largest = pass->plans.plan[e].value_count;
  }
  if (!hv_mul_size(largest, f.T, &slot_values)) {
    return HV_FAIL(ctx, HETINV_ERROR_SIZE_OVERFLOW, "%zu values times %d tangents overflow",
                   largest, (int)tangents);
  }
  int threads, slots = hv_pass_slot_count(
      pass, slot_values <= SIZE_MAX / sizeof(double) ? slot_values * sizeof(double) : SIZE_MAX,
      &threads);
  f.tallies = hv_calloc(ctx, (size_t)slots, sizeof *f.tallies);
  f.grads = hv_calloc(ctx, (size_t)slots, sizeof *f.grads);
  f.total = values;
  memset(values, 0, n * sizeof(double));
  if (std_errors) {
    f.mean_sum = hv_calloc(ctx, n ? n : 1, sizeof(double));
    f.mean_sq = hv_calloc(ctx, n ? n : 1, sizeof(double));
  }
  bool ok = f.tallies && f.grads && (std_errors == NULL || (f.mean_sum && f.mean_sq)) &&
            sparsify(ctx, tangent, 3 * voxels, f.T, &f);
  for (int t = 0; ok && t < slots; ++t) {
    hv_grad_tally_t *gt = &f.grads[t];
    gt->path.ctx = gt->chain.ctx = ctx;
    gt->voxels = voxels;
    gt->jvp = (hv_jvp_state_t){.grid = &pass->grid, .tangent = tangent, .tangents = tangents,
                               .voxels = voxels, .sparse_start = f.sparse_start,
                               .sparse_index = f.sparse_index, .sparse_value = f.sparse_value};
    gt->jvp.run = hv_calloc_apart(ctx, 2 * f.T, sizeof(double));
    f.tallies[t].values = hv_calloc_apart(ctx, slot_values ? slot_values : 1, sizeof(double));
    f.tallies[t].grad = gt;
    ok = gt->jvp.run && f.tallies[t].values;
  }
  if (ok) {
    hv_batch_loop_t loop = {(int64_t)(pass->emitter_hi - pass->emitter_lo) * pass->batches,
                            threads, &f, run_item, reduce_item, slots};
    hv_batches_run(&loop);
    ok = !f.out_of_memory;
  }
  hetinv_result_t r = HETINV_SUCCESS;
  if (!ok) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                "cannot allocate the tangent buffers for %zu values and %d tangents", count,
                (int)tangents);
  } else {
    double photons = (double)pass->photons;
    for (size_t k = 0; k < n; ++k) {
      values[k] /= photons;
      if (std_errors) std_errors[k] = hv_batch_std_error(f.mean_sum[k], f.mean_sq[k], pass->batches);
    }
  }
  release(ctx, &f, slots);
  return r;
}

HETINV_API hetinv_result_t hetinv_estimator_jvp(hetinv_estimator_t *estimator,
                                                const hetinv_medium_t *medium,
                                                const hetinv_measurements_t *set,
                                                const hetinv_param_map_t *map, const double *v,
                                                size_t v_count, double *jv, double *jv_std_errors,
                                                size_t count) {
  HV_API_ENTER();
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, count, &pass);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = pass.ctx;
  r = hv_check_pi_map(ctx, map, medium, v_count, "v_count");
  if (r == HETINV_SUCCESS && v == NULL) r = HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'v' is NULL");
  if (r == HETINV_SUCCESS && jv == NULL) r = HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'jv' is NULL");
  for (size_t i = 0; r == HETINV_SUCCESS && i < v_count; ++i) {
    if (!isfinite(v[i])) {
      r = HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "v[%zu] is %g; it must be finite", i, v[i]);
    }
  }
  double *tangent = NULL;
  if (r == HETINV_SUCCESS) {
    tangent = hv_calloc(ctx, 3 * medium->voxel_count, sizeof(double));
    if (tangent == NULL) r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the tangent");
  }
  if (r == HETINV_SUCCESS) {
    hv_param_map_pushforward(map, v, 1, tangent);
    r = hv_tangent_run(&pass, tangent, 1, count, jv, jv_std_errors);
  }
  hv_free(ctx, tangent);
  hv_pass_end(&pass);
  return r;
}
