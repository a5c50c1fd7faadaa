#include "estimator/pass.h"

#include <stdbool.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/alloc.h"
#include "core/comm.h"
#include "core/context_internal.h"
#include "core/error.h"
#include "core/hash.h"
#include "estimator/batches.h"
#include "estimator/set_hash.h"
#include "medium/medium_internal.h"
#include "sampling/measurements_internal.h"
#include "transport/lanes.h"
#include "transport/sensor_kind.h"

/* Epoch 0 keeps the context's seed; others map (seed, epoch) to a new key
 * through SplitMix64's finaliser. */
static uint64_t hv_mix_seed(uint64_t seed, uint64_t epoch) {
  if (epoch == 0) return seed;
  uint64_t z = seed ^ (epoch * 0x9e3779b97f4a7c15ULL);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

double hv_now_seconds(void) {
#ifdef _OPENMP
  return omp_get_wtime();
#else
  return 0.0;
#endif
}

/* The axis-parallel walks the plans' sensors make (sensor_kind.h). */
static uint32_t axis_walks(const hv_plans_t *plans) {
  uint32_t faces = 0;
  for (int32_t i = 0; i < plans->count; ++i) {
    const hv_plan_t *p = &plans->plan[i];
    for (int32_t j = 0; j < p->target_count; ++j) {
      const hv_sensor_target_t *t = &p->targets[j];
      if (t->kind->axis_walks) faces |= t->kind->axis_walks(t->sensor);
    }
  }
  return faces;
}

/* Each thread but the first reads its own copy of a large grid's voxel
 * records and acceptance bytes. Two cores reading the same lines of arrays
 * larger than their caches serve each other's misses: A1-het's two-thread
 * render used 6-8 % more CPU than its one-thread render, and none with a
 * copy per thread (docs/results/kernel.md). Copies only for arrays past
 * HV_COPY_MIN_BYTES (smaller ones stay in each core's cache) and within
 * HV_COPY_BUDGET in all; none if memory runs out, which changes nothing but
 * speed: the copies are bitwise the grid's. */
#define HV_COPY_MIN_BYTES ((size_t)1 << 20)
#define HV_COPY_BUDGET ((size_t)1 << 30)

static void copy_grid_per_thread(hv_pass_t *pass) {
#ifdef _OPENMP
  size_t bytes = hv_grid_voxel_bytes(&pass->grid);
  int copies = pass->threads - 1;
  if (pass->grid.uniform || copies < 1 || bytes < HV_COPY_MIN_BYTES || bytes > HV_COPY_BUDGET / (size_t)copies) {
    return;
  }
  pass->grid_copies = hv_calloc(pass->ctx, (size_t)copies, sizeof *pass->grid_copies);
  pass->grid_copy_filled = hv_calloc(pass->ctx, (size_t)copies, sizeof *pass->grid_copy_filled);
  if (pass->grid_copies == NULL || pass->grid_copy_filled == NULL) return;
  while (pass->grid_copy_count < copies && hv_grid_copy_take(&pass->grid, pass->grid_store, pass->grid_copy_count + 1,
                                                             &pass->grid_copies[pass->grid_copy_count])) {
    ++pass->grid_copy_count;
  }
#else
  (void)pass; /* without OpenMP one thread traces every batch */
#endif
}

hetinv_result_t hv_pass_begin(const hetinv_estimator_t *est, const hetinv_medium_t *medium,
                              const hetinv_measurements_t *set, size_t count, hv_pass_t *pass) {
  *pass = (hv_pass_t){0};
  if (est == NULL) return HV_FAIL(NULL, HETINV_ERROR_NULL_ARGUMENT, "'estimator' is NULL");
  const hetinv_context_t *ctx = est->ctx;
  if (medium == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'medium' is NULL");
  if (set == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'set' is NULL");
  if (!medium->committed) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE, "the medium is not committed");
  }
  if (set->row_count == 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "the measurement set has no rows");
  }
  if (count != set->value_count) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "count is %zu; the measurement set has %zu values", count, set->value_count);
  }
  hetinv_result_t checked = hv_measurements_check_medium(ctx, set, medium);
  if (checked != HETINV_SUCCESS) return checked;
  *pass = (hv_pass_t){.ctx = ctx,
                      .start_seconds = hv_now_seconds(),
                      .grad_scratch = est->grad_scratch,
                      .grid_store = est->grid_store};
  hetinv_result_t r = hv_grid_build(medium, pass->grid_store, &pass->grid);
  if (r != HETINV_SUCCESS) return r;
  r = hv_plans_build(set, &pass->plans);
  if (r != HETINV_SUCCESS) {
    hv_grid_release(&pass->grid);
    return r;
  }
  r = hv_grid_build_axis_depths(&pass->grid, axis_walks(&pass->plans));
  if (r != HETINV_SUCCESS) {
    hv_plans_release(&pass->plans);
    hv_grid_release(&pass->grid);
    return r;
  }
  const double *param = est->param;
  hv_exp_table_init(&pass->exp_table);
  pass->tracer = (hv_tracer_t){
      .grid = &pass->grid,
      .exp_table = &pass->exp_table,
      .roulette_weight = param[HETINV_ESTIMATOR_ROULETTE_WEIGHT],
      .roulette_survival = param[HETINV_ESTIMATOR_ROULETTE_SURVIVAL],
      .min_scattering = (int32_t)param[HETINV_ESTIMATOR_MIN_SCATTERING],
      .max_scattering = (int32_t)param[HETINV_ESTIMATOR_MAX_SCATTERING],
  };
  pass->seed = hv_mix_seed(ctx->seed, (uint64_t)param[HETINV_ESTIMATOR_EPOCH]);
  pass->photons = (uint64_t)param[HETINV_ESTIMATOR_PHOTONS];
  pass->stream = (uint32_t)param[HETINV_ESTIMATOR_STREAM];
  pass->batches = (int32_t)param[HETINV_ESTIMATOR_BATCHES];
  if ((uint64_t)pass->batches > pass->photons) pass->batches = (int32_t)pass->photons;
  pass->threads = ctx->thread_count;
  copy_grid_per_thread(pass);
  pass->rank = ctx->rank;
  pass->ranks = ctx->rank_count;
  int64_t lo, hi;
  hv_comm_block(pass->plans.count, pass->rank, pass->ranks, &lo, &hi);
  pass->emitter_lo = (int32_t)lo;
  pass->emitter_hi = (int32_t)hi;
  return HETINV_SUCCESS;
}

/* Tally slots of a pass in all: each is as large as the set's values
 * (render) or 33 bytes per voxel (gradient), so a large set on many threads
 * would otherwise ask for terabytes (1024 threads × 2^26 values × 16 bytes). */
#define HV_TALLY_BUDGET ((size_t)4 << 30)

int hv_pass_slot_count(const hv_pass_t *pass, size_t bytes_per_slot, int *threads) {
  int64_t items = (int64_t)(pass->emitter_hi - pass->emitter_lo) * pass->batches;
  bool spare = pass->threads > 1 && bytes_per_slot <= HV_BATCH_SPARE_SLOT_BYTES;
  int64_t s = (int64_t)pass->threads * (spare ? HV_BATCH_SLOTS_PER_THREAD : 1);
  if (items >= 1 && s > items) s = items;
  if (bytes_per_slot > 0 && (size_t)s > HV_TALLY_BUDGET / bytes_per_slot) {
    s = (int64_t)(HV_TALLY_BUDGET / bytes_per_slot);
  }
  if (s < 1) s = 1;
  *threads = pass->threads < s ? pass->threads : (int)s;
  if (*threads < 1) *threads = 1;
  return (int)s;
}

hetinv_result_t hv_pass_agree(const hetinv_estimator_t *est, const hetinv_medium_t *medium,
                              const hetinv_measurements_t *set, hetinv_result_t status, uint64_t call) {
  if (est == NULL || est->ctx->rank_count == 1) return status; /* no context to agree over, or nobody */
  uint64_t key = 0;
  if (status == HETINV_SUCCESS) { /* then medium and set are valid */
    key = hv_fnv1a(HV_FNV_OFFSET, est->param, sizeof est->param);
    key = hv_fnv1a(key, &est->gain_mode, sizeof est->gain_mode);
    key = hv_fnv1a(key, &est->ctx->seed, sizeof est->ctx->seed);
    uint64_t geometry = hv_set_geometry_hash(set);
    key = hv_fnv1a(key, &geometry, sizeof geometry);
    size_t voxels = hetinv_medium_voxel_count(medium);
    for (int p = 0; p < HETINV_PARAM_COUNT; ++p) key = hv_fnv1a_doubles(key, hetinv_medium_grid(medium, p), voxels);
    key = hv_fnv1a(key, &call, sizeof call);
  }
  return hv_comm_agree(est->ctx, status, key,
                       "the estimator's tunables or gain mode, the context's seed, the measurement set's geometry, "
                       "the medium, or the call's own arguments");
}

void hv_pass_end(hv_pass_t *pass) {
  hv_free(pass->ctx, pass->grid_copies);
  hv_free(pass->ctx, pass->grid_copy_filled);
  pass->grid_copies = NULL;
  pass->grid_copy_filled = NULL;
  pass->grid_copy_count = 0;
  hv_plans_release(&pass->plans);
  hv_grid_release(&pass->grid);
}

double hv_pass_batch_size(const hv_pass_t *pass, int32_t b) {
  return (double)(hv_batch_begin(pass->photons, pass->batches, b + 1) -
                  hv_batch_begin(pass->photons, pass->batches, b));
}

void hv_pass_trace_batch(const hv_pass_t *pass, int32_t e, int32_t b, hv_tally_t *tally) {
  const hv_plan_t *plan = &pass->plans.plan[e];
  uint64_t end = hv_batch_begin(pass->photons, pass->batches, b + 1);
  hv_tracer_t tracer = pass->tracer;
#ifdef _OPENMP
  int t = omp_get_thread_num();
  if (t >= 1 && t <= pass->grid_copy_count) {
    /* Only thread t ever touches copy t - 1. */
    if (!pass->grid_copy_filled[t - 1]) {
      hv_grid_copy_fill(&pass->grid, &pass->grid_copies[t - 1]);
      pass->grid_copy_filled[t - 1] = true;
    }
    tracer.grid = &pass->grid_copies[t - 1];
  }
#endif
  uint64_t begin = hv_batch_begin(pass->photons, pass->batches, b);
  if (hv_lanes_fit(&tracer, plan, tally)) {
    hv_trace_lanes(&tracer, plan, pass->seed, pass->stream, begin, end, tally);
    return;
  }
  for (uint64_t p = begin; p < end; ++p) {
    hv_rng_t rng = hv_rng_init(pass->seed, plan->key, p, pass->stream);
    hv_trace_photon(&tracer, plan, &rng, tally);
  }
}
