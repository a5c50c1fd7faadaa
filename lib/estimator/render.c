/* The forward pass: every emitter's photons in fixed batches, reduced in a
 * fixed order (batches.h); batch means give the standard errors.
 *
 * Every value belongs to one emitter's rows, so each value's sums are
 * complete on the rank that traces its emitter; statistics are kept per
 * emitter and summed over emitters in emitter order at the end. With
 * several ranks each traces its block of emitters and the blocks' sums are
 * gathered (share()), so the arithmetic is the same for any rank count. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/comm.h"
#include "core/error.h"
#include "estimator/batches.h"
#include "estimator/pass.h"
#include "estimator/record.h"

typedef struct forward {
  const hv_pass_t *pass;
  hv_tally_t *tallies; /* one per tally slot (batches.h) */
  /* Per value: the total, and the sum and sum of squares of batch means. */
  double *total, *mean_sum, *mean_sq, *ballistic;
  double (*stats_sum)[HV_STAT_COUNT];      /* per emitter */
  double (*stats_mean_sum)[HV_STAT_COUNT]; /* per emitter */
  double (*stats_mean_sq)[HV_STAT_COUNT];
} forward_t;

/* Items run emitter-major over this rank's emitters: item = (e - lo)·B + b. */
static void run_item(void *self, int64_t item, int slot) {
  forward_t *f = self;
  hv_tally_t *tally = &f->tallies[slot];
  int32_t e = f->pass->emitter_lo + (int32_t)(item / f->pass->batches);
  const hv_plan_t *plan = &f->pass->plans.plan[e];
  for (int32_t i = 0; i < plan->range_count; ++i) {
    size_t n = plan->range_hi[i] - plan->range_lo[i];
    memset(tally->values + plan->range_lo[i], 0, n * sizeof(double));
    if (tally->ballistic) memset(tally->ballistic + plan->range_lo[i], 0, n * sizeof(double));
  }
  memset(tally->stats, 0, sizeof tally->stats);
  hv_pass_trace_batch(f->pass, e, (int32_t)(item % f->pass->batches), tally);
}

static void reduce_item(void *self, int64_t item, int slot) {
  forward_t *f = self;
  const hv_tally_t *tally = &f->tallies[slot];
  const hv_pass_t *pass = f->pass;
  int32_t e = pass->emitter_lo + (int32_t)(item / pass->batches);
  int32_t b = (int32_t)(item % pass->batches);
  const hv_plan_t *plan = &pass->plans.plan[e];
  double n = hv_pass_batch_size(pass, b);
  for (int32_t i = 0; i < plan->range_count; ++i) {
    for (size_t k = plan->range_lo[i]; k < plan->range_hi[i]; ++k) {
      double x = tally->values[k], m = x / n;
      f->total[k] += x;
      f->mean_sum[k] += m;
      f->mean_sq[k] += m * m;
      if (f->ballistic) f->ballistic[k] += tally->ballistic[k];
    }
  }
  for (int s = 0; s < HV_STAT_COUNT; ++s) {
    double m = tally->stats[s] / n;
    f->stats_sum[e][s] += tally->stats[s];
    f->stats_mean_sum[e][s] += m;
    f->stats_mean_sq[e][s] += m * m;
  }
}

static void fill_stats(hetinv_estimator_t *est, const forward_t *f) {
  const hv_pass_t *pass = f->pass;
  hetinv_render_stats_t *st = &est->stats;
  *st = (hetinv_render_stats_t){.size = sizeof *st};
  int32_t emitters = pass->plans.count;
  st->photons = pass->photons * (uint64_t)emitters;
  double norm = (double)pass->photons * emitters;
  double var[HV_STAT_COUNT] = {0}, total[HV_STAT_COUNT] = {0};
  for (int32_t e = 0; e < emitters; ++e) {
    for (int s = 0; s < HV_STAT_COUNT; ++s) {
      total[s] += f->stats_sum[e][s];
      double se = hv_batch_std_error(f->stats_mean_sum[e][s], f->stats_mean_sq[e][s], pass->batches);
      var[s] += se * se;
    }
  }
  /* Averages over emitters of each emitter's mean. */
  st->specular = total[HV_STAT_SPECULAR] / norm;
  st->absorbed = total[HV_STAT_ABSORBED] / norm;
  st->absorbed_std_error = sqrt(var[HV_STAT_ABSORBED]) / emitters;
  for (int face = 0; face < 6; ++face) {
    st->escaped[face] = total[HV_STAT_ESCAPED + face] / norm;
    st->escaped_std_error[face] = sqrt(var[HV_STAT_ESCAPED + face]) / emitters;
  }
  st->truncated = total[HV_STAT_TRUNCATED] / norm;
  st->truncated_paths = (uint64_t)total[HV_STAT_TRUNCATED_PATHS]; /* exact below 2^53 */
  st->seconds = hv_now_seconds() - pass->start_seconds;
  est->has_stats = true;
}

/* Hands every rank's emitters' sums to every rank: per emitter, in emitter
 * order, each of its values' (total, Σ batch means, Σ squares[, ballistic])
 * and its statistics' (sum, Σ batch means, Σ squares). Collective. */
static hetinv_result_t share(forward_t *f, bool with_ballistic, hetinv_result_t status) {
  const hv_pass_t *pass = f->pass;
  const hetinv_context_t *ctx = pass->ctx;
  size_t per_value = with_ballistic ? 4 : 3;
  hv_record_t rec = {.ctx = ctx};
  for (int32_t e = pass->emitter_lo; status == HETINV_SUCCESS && e < pass->emitter_hi; ++e) {
    const hv_plan_t *plan = &pass->plans.plan[e];
    for (int32_t i = 0; i < plan->range_count; ++i) {
      if (!hv_record_reserve(&rec, (plan->range_hi[i] - plan->range_lo[i]) * per_value)) break;
      for (size_t k = plan->range_lo[i]; k < plan->range_hi[i]; ++k) {
        hv_record_put(&rec, f->total[k]);
        hv_record_put(&rec, f->mean_sum[k]);
        hv_record_put(&rec, f->mean_sq[k]);
        if (with_ballistic) hv_record_put(&rec, f->ballistic[k]);
      }
    }
    if (!hv_record_reserve(&rec, 3 * HV_STAT_COUNT)) break;
    for (int s = 0; s < HV_STAT_COUNT; ++s) {
      hv_record_put(&rec, f->stats_sum[e][s]);
      hv_record_put(&rec, f->stats_mean_sum[e][s]);
      hv_record_put(&rec, f->stats_mean_sq[e][s]);
    }
  }
  if (status == HETINV_SUCCESS && rec.out_of_memory) {
    status = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                     "cannot allocate the partial sums of emitters %d to %d", (int)pass->emitter_lo,
                     (int)pass->emitter_hi - 1);
  }
  double *all = NULL;
  size_t all_count = 0, at = 0;
  hetinv_result_t r = hv_comm_allgather(ctx, rec.data, rec.count, status, &all, &all_count);
  hv_record_release(&rec);
  /* Rank blocks are contiguous and in rank order: the records of every
   * emitter, in emitter order. */
  bool fits = true; /* every emitter's records are there, not fewer (nor more: below) */
  for (int32_t e = 0; r == HETINV_SUCCESS && fits && e < pass->plans.count; ++e) {
    const hv_plan_t *plan = &pass->plans.plan[e];
    size_t need = 3 * HV_STAT_COUNT;
    for (int32_t i = 0; i < plan->range_count; ++i) {
      need += (plan->range_hi[i] - plan->range_lo[i]) * per_value;
    }
    fits = all_count - at >= need;
    if (!fits) break;
    for (int32_t i = 0; i < plan->range_count; ++i) {
      for (size_t k = plan->range_lo[i]; k < plan->range_hi[i]; ++k) {
        f->total[k] = all[at++];
        f->mean_sum[k] = all[at++];
        f->mean_sq[k] = all[at++];
        if (with_ballistic) f->ballistic[k] = all[at++];
      }
    }
    for (int s = 0; s < HV_STAT_COUNT; ++s) {
      f->stats_sum[e][s] = all[at++];
      f->stats_mean_sum[e][s] = all[at++];
      f->stats_mean_sq[e][s] = all[at++];
    }
  }
  if (r == HETINV_SUCCESS && (!fits || at != all_count)) {
    r = HV_FAIL(ctx, HETINV_ERROR_INTERNAL,
                "the ranks' partial sums hold %zu doubles, which do not match the rows of the %d "
                "emitters", all_count, (int)pass->plans.count);
  }
  hv_free(ctx, all);
  return r;
}

static void release(const hetinv_context_t *ctx, forward_t *f, int slots) {
  for (int t = 0; f->tallies && t < slots; ++t) {
    hv_free(ctx, f->tallies[t].values);
    hv_free(ctx, f->tallies[t].ballistic);
  }
  hv_free(ctx, f->tallies);
  hv_free(ctx, f->total);
  hv_free(ctx, f->mean_sum);
  hv_free(ctx, f->mean_sq);
  hv_free(ctx, f->ballistic);
  hv_free(ctx, f->stats_sum);
  hv_free(ctx, f->stats_mean_sum);
  hv_free(ctx, f->stats_mean_sq);
}

hetinv_result_t hv_forward_run(hetinv_estimator_t *est, const hv_pass_t *pass, double *values,
                               double *std_errors, double *ballistic, size_t count) {
  const hetinv_context_t *ctx = pass->ctx;
  forward_t f = {.pass = pass};
  int threads, slots = hv_pass_slot_count(pass, count * sizeof(double) * (ballistic ? 2 : 1), &threads);
  f.tallies = hv_calloc(ctx, (size_t)slots, sizeof *f.tallies);
  f.total = hv_calloc(ctx, count, sizeof(double));
  f.mean_sum = hv_calloc(ctx, count, sizeof(double));
  f.mean_sq = hv_calloc(ctx, count, sizeof(double));
  if (ballistic) f.ballistic = hv_calloc(ctx, count, sizeof(double));
  f.stats_sum = hv_calloc(ctx, (size_t)pass->plans.count, sizeof *f.stats_sum);
  f.stats_mean_sum = hv_calloc(ctx, (size_t)pass->plans.count, sizeof *f.stats_mean_sum);
  f.stats_mean_sq = hv_calloc(ctx, (size_t)pass->plans.count, sizeof *f.stats_mean_sq);
  bool ok = f.tallies && f.total && f.mean_sum && f.mean_sq && (!ballistic || f.ballistic) &&
            f.stats_sum && f.stats_mean_sum && f.stats_mean_sq;
  for (int t = 0; ok && t < slots; ++t) {
    f.tallies[t].values = hv_calloc_apart(ctx, count, sizeof(double));
    if (ballistic) f.tallies[t].ballistic = hv_calloc_apart(ctx, count, sizeof(double));
    ok = f.tallies[t].values && (!ballistic || f.tallies[t].ballistic);
  }
  hetinv_result_t r = HETINV_SUCCESS;
  if (ok) {
    hv_batch_loop_t loop = {(int64_t)(pass->emitter_hi - pass->emitter_lo) * pass->batches,
                            threads, &f, run_item, reduce_item, slots};
    hv_batches_run(&loop);
  } else {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                "cannot allocate the render buffers for %zu values", count);
  }
  /* Collective: a rank that failed above still takes part, with its code. */
  if (pass->ranks > 1) r = share(&f, ballistic != NULL, r);
  if (r == HETINV_SUCCESS) {
    double n = (double)pass->photons;
    for (size_t k = 0; k < count; ++k) {
      values[k] = f.total[k] / n;
      if (std_errors) std_errors[k] = hv_batch_std_error(f.mean_sum[k], f.mean_sq[k], pass->batches);
      if (ballistic) ballistic[k] = f.ballistic[k] / n;
    }
    fill_stats(est, &f);
  }
  release(ctx, &f, slots);
  return r;
}

HETINV_API hetinv_result_t hetinv_estimator_render(hetinv_estimator_t *estimator,
                                                   const hetinv_medium_t *medium,
                                                   const hetinv_measurements_t *set,
                                                   double *values, double *std_errors,
                                                   double *ballistic, size_t count) {
  HV_API_ENTER();
  hv_pass_t pass;
  hetinv_result_t r = hv_pass_begin(estimator, medium, set, count, &pass);
  if (r == HETINV_SUCCESS && values == NULL) r = HV_FAIL(pass.ctx, HETINV_ERROR_NULL_ARGUMENT, "'values' is NULL");
  /* The call's own part of the ranks' key: a render, and whether it
   * gathers ballistic light (which the ranks' records hold). */
  const uint64_t call = ballistic != NULL ? UINT64_C(0x52454e4442) : UINT64_C(0x52454e44);
  r = hv_pass_agree(estimator, medium, set, r, call);
  if (r == HETINV_SUCCESS) r = hv_forward_run(estimator, &pass, values, std_errors, ballistic, count);
  hv_pass_end(&pass);
  return r;
}
