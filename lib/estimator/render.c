/* The forward pass: photons of every emitter in fixed batches, batches run
 * in parallel rounds and reduced in a fixed order, so the result does not
 * depend on the thread count; batch means give the standard errors. */
#include <math.h>
#include <string.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/alloc.h"
#include "core/context_internal.h"
#include "core/error.h"
#include "estimator/estimator_internal.h"
#include "medium/medium_internal.h"
#include "sampling/measurements_internal.h"
#include "transport/tracer.h"

/* Running sums over batches: per value, the total, and the sum and sum of
 * squares of the per-photon batch means. */
typedef struct accum {
  double *total, *mean_sum, *mean_sq, *ballistic;
  double stats_total[HV_STAT_COUNT];
  double (*stats_mean_sum)[HV_STAT_COUNT]; /* per emitter */
  double (*stats_mean_sq)[HV_STAT_COUNT];
} accum_t;

/* Work item i is batch i % batches of emitter i / batches. */
typedef struct job {
  const hv_tracer_t *tracer;
  const hv_plans_t *plans;
  uint64_t seed, photons;
  uint32_t stream;
  int32_t batches;
} job_t;

static uint64_t batch_begin(const job_t *j, int32_t b) {
  return (uint64_t)((double)j->photons * b / j->batches); /* exact for photons < 2^53 */
}

static void run_item(const job_t *j, int64_t item, hv_tally_t *tally) {
  const hv_plan_t *plan = &j->plans->plan[item / j->batches];
  int32_t b = (int32_t)(item % j->batches);
  for (int32_t i = 0; i < plan->range_count; ++i) {
    size_t n = plan->range_hi[i] - plan->range_lo[i];
    memset(tally->values + plan->range_lo[i], 0, n * sizeof(double));
    if (tally->ballistic) memset(tally->ballistic + plan->range_lo[i], 0, n * sizeof(double));
  }
  memset(tally->stats, 0, sizeof tally->stats);
  for (uint64_t p = batch_begin(j, b), end = batch_begin(j, b + 1); p < end; ++p) {
    hv_rng_t rng = hv_rng_init(j->seed, plan->key, p, j->stream);
    hv_trace_photon(j->tracer, plan, &rng, tally);
  }
}

static void reduce_item(const job_t *j, int64_t item, const hv_tally_t *tally, accum_t *acc) {
  int32_t e = (int32_t)(item / j->batches), b = (int32_t)(item % j->batches);
  const hv_plan_t *plan = &j->plans->plan[e];
  double n = (double)(batch_begin(j, b + 1) - batch_begin(j, b));
  for (int32_t i = 0; i < plan->range_count; ++i) {
    for (size_t k = plan->range_lo[i]; k < plan->range_hi[i]; ++k) {
      double x = tally->values[k], m = x / n;
      acc->total[k] += x;
      acc->mean_sum[k] += m;
      acc->mean_sq[k] += m * m;
      if (acc->ballistic) acc->ballistic[k] += tally->ballistic[k];
    }
  }
  for (int s = 0; s < HV_STAT_COUNT; ++s) {
    double m = tally->stats[s] / n;
    acc->stats_total[s] += tally->stats[s];
    acc->stats_mean_sum[e][s] += m;
    acc->stats_mean_sq[e][s] += m * m;
  }
}

/* Standard error of a mean from B batch means (their sum and sum of squares). */
static double std_error(double sum, double sq, int32_t batches) {
  double mean = sum / batches, var = (sq / batches - mean * mean) * batches / (batches - 1);
  return var > 0.0 ? sqrt(var / batches) : 0.0;
}

/* Validates the call; on success the set's geometry matches the medium. */
static hetinv_result_t check_render(const hetinv_estimator_t *est, const hetinv_medium_t *medium,
                                    const hetinv_measurements_t *set, const double *values,
                                    size_t count, const char *func) {
  if (est == NULL) return hv_fail(NULL, HETINV_ERROR_NULL_ARGUMENT, func, "'estimator' is NULL");
  const hetinv_context_t *ctx = est->ctx;
  if (medium == NULL) return hv_fail(ctx, HETINV_ERROR_NULL_ARGUMENT, func, "'medium' is NULL");
  if (set == NULL) return hv_fail(ctx, HETINV_ERROR_NULL_ARGUMENT, func, "'set' is NULL");
  if (values == NULL) return hv_fail(ctx, HETINV_ERROR_NULL_ARGUMENT, func, "'values' is NULL");
  if (!medium->committed) {
    return hv_fail(ctx, HETINV_ERROR_INVALID_STATE, func, "the medium is not committed");
  }
  if (set->row_count == 0) {
    return hv_fail(ctx, HETINV_ERROR_INVALID_ARGUMENT, func, "the measurement set has no rows");
  }
  if (count != set->value_count) {
    return hv_fail(ctx, HETINV_ERROR_INVALID_ARGUMENT, func,
                   "count is %zu; the measurement set has %zu values", count, set->value_count);
  }
  hv_geometry_t geo;
  hv_geometry_of(medium, &geo);
  if (!hv_geometry_equal(&geo, &set->geo)) {
    return hv_fail(ctx, HETINV_ERROR_INVALID_ARGUMENT, func,
                   "the medium's box [%g, %g] x [%g, %g] x [%g, %g] with eta %g / %g differs from "
                   "the box [%g, %g] x [%g, %g] x [%g, %g] with eta %g / %g the set was made for",
                   geo.lo[0], geo.hi[0], geo.lo[1], geo.hi[1], geo.lo[2], geo.hi[2], geo.eta,
                   geo.eta_out, set->geo.lo[0], set->geo.hi[0], set->geo.lo[1], set->geo.hi[1],
                   set->geo.lo[2], set->geo.hi[2], set->geo.eta, set->geo.eta_out);
  }
  return HETINV_SUCCESS;
}

static double now_seconds(void) {
#ifdef _OPENMP
  return omp_get_wtime();
#else
  return 0.0;
#endif
}

/* Runs every work item in rounds of `threads` items and reduces each round
 * in item order. Returns false if a per-thread buffer could not be allocated. */
static bool run_rounds(const job_t *job, int threads, size_t value_count, bool want_ballistic,
                       accum_t *acc, const hetinv_context_t *ctx) {
  int64_t items = (int64_t)job->plans->count * job->batches;
  hv_tally_t *tallies = hv_calloc(ctx, (size_t)threads, sizeof *tallies);
  bool ok = tallies != NULL;
  for (int t = 0; ok && t < threads; ++t) {
    tallies[t].values = hv_calloc(ctx, value_count, sizeof(double));
    if (want_ballistic) tallies[t].ballistic = hv_calloc(ctx, value_count, sizeof(double));
    ok = tallies[t].values && (!want_ballistic || tallies[t].ballistic);
  }
  if (ok) {
#pragma omp parallel num_threads(threads)
    {
      int tid = 0;
#ifdef _OPENMP
      tid = omp_get_thread_num();
#endif
      for (int64_t first = 0; first < items; first += threads) {
        if (first + tid < items) run_item(job, first + tid, &tallies[tid]);
#pragma omp barrier
#pragma omp single
        for (int t = 0; t < threads && first + t < items; ++t) reduce_item(job, first + t, &tallies[t], acc);
        /* the single's implicit barrier keeps the tallies until reduced */
      }
    }
  }
  for (int t = 0; tallies && t < threads; ++t) {
    hv_free(ctx, tallies[t].values);
    hv_free(ctx, tallies[t].ballistic);
  }
  hv_free(ctx, tallies);
  return ok;
}

static void fill_stats(hetinv_estimator_t *est, const job_t *job, const accum_t *acc) {
  hetinv_render_stats_t *st = &est->stats;
  *st = (hetinv_render_stats_t){.size = sizeof *st};
  int32_t emitters = job->plans->count;
  st->photons = job->photons * (uint64_t)emitters;
  double scale = 1.0 / ((double)job->photons * emitters);
  double var[HV_STAT_COUNT] = {0};
  for (int32_t e = 0; e < emitters; ++e) {
    for (int s = 0; s < HV_STAT_COUNT; ++s) {
      double se = std_error(acc->stats_mean_sum[e][s], acc->stats_mean_sq[e][s], job->batches);
      var[s] += se * se;
    }
  }
  /* The stats are averages over emitters of each emitter's mean. */
  st->specular = acc->stats_total[HV_STAT_SPECULAR] * scale;
  st->absorbed = acc->stats_total[HV_STAT_ABSORBED] * scale;
  st->absorbed_std_error = sqrt(var[HV_STAT_ABSORBED]) / emitters;
  for (int f = 0; f < 6; ++f) {
    st->escaped[f] = acc->stats_total[HV_STAT_ESCAPED + f] * scale;
    st->escaped_std_error[f] = sqrt(var[HV_STAT_ESCAPED + f]) / emitters;
  }
  st->truncated = acc->stats_total[HV_STAT_TRUNCATED] * scale;
  est->has_stats = true;
}

HETINV_API hetinv_result_t hetinv_estimator_render(hetinv_estimator_t *estimator,
                                                   const hetinv_medium_t *medium,
                                                   const hetinv_measurements_t *set,
                                                   double *values, double *std_errors,
                                                   double *ballistic, size_t count) {
  hetinv_result_t r = check_render(estimator, medium, set, values, count, __func__);
  if (r != HETINV_SUCCESS) return r;
  const hetinv_context_t *ctx = estimator->ctx;
  double start = now_seconds();
  const double *param = estimator->param;
  hv_grid_t grid;
  r = hv_grid_build(medium, __func__, &grid);
  if (r != HETINV_SUCCESS) return r;
  hv_plans_t plans;
  r = hv_plans_build(set, __func__, &plans);
  if (r != HETINV_SUCCESS) {
    hv_grid_release(&grid);
    return r;
  }
  hv_tracer_t tracer = {
      .grid = &grid,
      .roulette_weight = param[HETINV_ESTIMATOR_ROULETTE_WEIGHT],
      .roulette_survival = param[HETINV_ESTIMATOR_ROULETTE_SURVIVAL],
      .min_scattering = (int32_t)param[HETINV_ESTIMATOR_MIN_SCATTERING],
      .max_scattering = (int32_t)param[HETINV_ESTIMATOR_MAX_SCATTERING],
  };
  job_t job = {
      .tracer = &tracer,
      .plans = &plans,
      .seed = ctx->seed,
      .photons = (uint64_t)param[HETINV_ESTIMATOR_PHOTONS],
      .stream = (uint32_t)param[HETINV_ESTIMATOR_STREAM],
      .batches = (int32_t)param[HETINV_ESTIMATOR_BATCHES],
  };
  if ((uint64_t)job.batches > job.photons) job.batches = (int32_t)job.photons;
  if (job.batches < 2) job.batches = 1; /* one photon: no error estimate */

  accum_t acc = {0};
  acc.total = hv_calloc(ctx, count, sizeof(double));
  acc.mean_sum = hv_calloc(ctx, count, sizeof(double));
  acc.mean_sq = hv_calloc(ctx, count, sizeof(double));
  if (ballistic) acc.ballistic = hv_calloc(ctx, count, sizeof(double));
  acc.stats_mean_sum = hv_calloc(ctx, (size_t)plans.count, sizeof *acc.stats_mean_sum);
  acc.stats_mean_sq = hv_calloc(ctx, (size_t)plans.count, sizeof *acc.stats_mean_sq);
  bool ok = acc.total && acc.mean_sum && acc.mean_sq && (!ballistic || acc.ballistic) &&
            acc.stats_mean_sum && acc.stats_mean_sq;
  int threads = ctx->thread_count;
  ok = ok && run_rounds(&job, threads, count, ballistic != NULL, &acc, ctx);
  if (ok) {
    double inv_n = 1.0 / (double)job.photons;
    for (size_t k = 0; k < count; ++k) {
      values[k] = acc.total[k] * inv_n;
      if (std_errors) std_errors[k] = job.batches > 1 ? std_error(acc.mean_sum[k], acc.mean_sq[k], job.batches) : 0.0;
      if (ballistic) ballistic[k] = acc.ballistic[k] * inv_n;
    }
    fill_stats(estimator, &job, &acc);
    estimator->stats.seconds = now_seconds() - start;
  }
  hv_free(ctx, acc.total);
  hv_free(ctx, acc.mean_sum);
  hv_free(ctx, acc.mean_sq);
  hv_free(ctx, acc.ballistic);
  hv_free(ctx, acc.stats_mean_sum);
  hv_free(ctx, acc.stats_mean_sq);
  hv_plans_release(&plans);
  hv_grid_release(&grid);
  if (!ok) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the render buffers for %zu values", count);
  return HETINV_SUCCESS;
}
