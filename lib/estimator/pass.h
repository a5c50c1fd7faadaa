/* What the forward and gradient passes share: validation of a render call
 * and the grid, plans and tracer built for it. */
#ifndef HV_PASS_H
#define HV_PASS_H

#include "estimator/estimator_internal.h"
#include "transport/tracer.h"

typedef struct hv_pass {
  const hetinv_context_t *ctx;
  hv_grid_t grid;
  hv_plans_t plans;
  hv_tracer_t tracer;
  hv_exp_table_t exp_table;
  uint64_t seed, photons;
  uint32_t stream;
  int32_t batches;
  int threads;
  double start_seconds;
  /* Distribution (core/comm.h): this rank traces emitters [emitter_lo,
   * emitter_hi) of plans.count; with ranks == 1 that is all of them. */
  int32_t rank, ranks;
  int32_t emitter_lo, emitter_hi;
  struct hv_grad_scratch *grad_scratch; /* the estimator's (grad_scratch.h) */
  hv_grid_store_t *grid_store;          /* the estimator's: grid's and copies' per-voxel arrays */
  /* Threads 1 .. grid_copy_count trace in their own copy of the grid's
   * per-voxel arrays (pass.c: copy_grid_per_thread), slots 1 .. of
   * grid_store; the others in grid. */
  hv_grid_t *grid_copies;
  int grid_copy_count;
  bool *grid_copy_filled; /* copy i is filled by its thread on first use */
} hv_pass_t;

/* Validates (estimator, medium, set, count) and builds the pass; on failure
 * the pass is empty: nothing needs releasing, and hv_pass_end is a no-op. */
hetinv_result_t hv_pass_begin(const hetinv_estimator_t *est, const hetinv_medium_t *medium,
                              const hetinv_measurements_t *set, size_t count, hv_pass_t *pass);
void hv_pass_end(hv_pass_t *pass);

/* Collective when the estimator's context has several ranks (one rank:
 * returns status): every rank of a render, gradient or loss-gradient call
 * comes here after hv_pass_begin and its own checks and allocations, with
 * its status so far, before its first other collective; `call` hashes the
 * call's own arguments every rank must pass alike (its kind, cotangent,
 * ...). All ranks then fail alike, naming the failing rank, or, when the
 * estimator's tunables, the context's seed, the set's geometry, the medium
 * or `call` differ between ranks, with INVALID_ARGUMENT. Without this a
 * rank that failed alone left the others waiting forever, and ranks given
 * different photon counts or media returned mixed results. The pass may
 * have failed to begin (then it is empty); hv_pass_end releases it either
 * way. */
hetinv_result_t hv_pass_agree(const hetinv_estimator_t *est, const hetinv_medium_t *medium,
                              const hetinv_measurements_t *set, hetinv_result_t status, uint64_t call);

/* Traces batch b's photons [hv_batch_begin(b), hv_batch_begin(b+1)) of
 * plan (emitter) e into tally. */
void hv_pass_trace_batch(const hv_pass_t *pass, int32_t e, int32_t b, hv_tally_t *tally);

/* Tally slots of a pass (hv_batch_loop_t) when each holds bytes_per_slot:
 * HV_BATCH_SLOTS_PER_THREAD per thread when several threads run and a slot
 * holds at most HV_BATCH_SPARE_SLOT_BYTES, else one per thread; no more than its work items
 * (emitters × batches of this rank) and than fit in HV_TALLY_BUDGET bytes
 * in all, at least 1; *threads gets the threads to run, at most the slots.
 * Results do not depend on either; only memory and speed do. */
int hv_pass_slot_count(const hv_pass_t *pass, size_t bytes_per_slot, int *threads);

/* Photons in batch b. */
double hv_pass_batch_size(const hv_pass_t *pass, int32_t b);

double hv_now_seconds(void);

/* The forward pass on a pass already begun (render.c); fills est's stats. */
hetinv_result_t hv_forward_run(hetinv_estimator_t *est, const hv_pass_t *pass, double *values,
                               double *std_errors, double *ballistic, size_t count);

/* The tangent pass (jvp.c) on a pass already begun: for T = `tangents`
 * voxel-space tangents (layout of hv_jvp_state_t), values[n·T + t] =
 * (J·v_t)_n and, if std_errors is not NULL, its standard error from the
 * batch means. count: the set's value count. One rank only. */
hetinv_result_t hv_tangent_run(const hv_pass_t *pass, const double *tangent, int32_t tangents,
                               size_t count, double *values, double *std_errors);

/* The gradient pass (gradient.c) on a pass already begun: grad = Jᵀ·cotangent
 * in π space, with standard errors if grad_se is not NULL. */
hetinv_result_t hv_gradient_run(const hv_pass_t *pass, const hetinv_param_map_t *map,
                                const double *cotangent, double *grad, double *grad_se);

/* Checks a parameter map against the medium and a π-sized argument whose
 * length `count` is named `what` in the message. */
hetinv_result_t hv_check_pi_map(const hetinv_context_t *ctx, const hetinv_param_map_t *map,
                                const hetinv_medium_t *medium, size_t count, const char *what);

#endif
