/* The optimizer's configuration and run state, shared by its files:
 * optimizer.c (configuration), minibatch.c (emitter groups and minibatch
 * sets), methods.c (descent steps), run.c (the iteration loop),
 * checkpoint.c (save/resume) and layerwise.c (Fig. 2(b) stages). */
#ifndef HV_OPTIMIZER_INTERNAL_H
#define HV_OPTIMIZER_INTERNAL_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "hetinv/optimizer.h"

typedef struct hv_stage {
  const hetinv_param_map_t *map;
  size_t k;           /* hetinv_param_map_size(map) */
  int64_t iterations; /* resolved when the run starts */
  int32_t requested;  /* the stage's own count, 0 = the ITERATIONS tunable */
  uint8_t *frozen;     /* k bytes or NULL */
  uint8_t *value_mask; /* value_count bytes or NULL */
  double epsilon_start; /* ADADELTA's ε at the stage's start (falls to the tunable); 0 = the tunable */
  int32_t average_window; /* the trailing iterates its result averages (at most the ring's); 0 = the ring's */
  /* The stage's last settle_fraction (0 = no settling part) runs at
   * settle_epsilon (0 = the stage's ε) and settle_photons × the estimator's
   * photons (0 = 1×, and no settling part of its own). */
  double settle_epsilon, settle_fraction, settle_photons;
} hv_stage_t;

/* Rows of the set grouped by emitter (in order of first use):
 * the rows of group e are rows[start[e] .. start[e+1]). */
typedef struct hv_emitter_groups {
  int32_t count;
  int32_t *start; /* count + 1 */
  int32_t *rows;  /* row_count */
} hv_emitter_groups_t;

struct hetinv_optimizer {
  hetinv_context_t *ctx;
  const hetinv_measurements_t *set;
  hetinv_medium_t *initial; /* committed copy of the initial medium */
  double param[HETINV_OPTIMIZER_PARAM_COUNT_];
  double lo[HETINV_PARAM_COUNT], hi[HETINV_PARAM_COUNT];
  hv_stage_t *stages;
  int32_t stage_count, stage_capacity;
  hetinv_progress_fn progress;
  void *user;
  char *checkpoint_path;
  hv_emitter_groups_t groups;

  /* Run state: everything below is what a checkpoint holds. */
  bool started;
  int32_t stage;           /* current stage */
  int64_t stage_iteration; /* iterations done in it */
  int64_t iteration;       /* iterations done in all stages */
  double elapsed;          /* seconds, across resumes */
  hetinv_medium_t *base;   /* uncommitted: the stage's π is applied over it */
  size_t k;                /* entries of the current stage (0 before it starts) */
  double *pi, *acc1, *acc2; /* iterate and the method's accumulators */
  double *ring;            /* the last `window` iterates, k each */
  int32_t ring_count, ring_head, window;
  double *losses;
  size_t loss_count, loss_capacity;
  /* The estimator's tunables of the run (EPOCH aside): saved, and checked
   * against the estimator a resumed run is given. */
  double est_param[HETINV_ESTIMATOR_PARAM_COUNT_];
  bool have_est_param, verify_est_param;
  hetinv_gain_mode_t gain_mode; /* the estimator's, likewise (checkpoints of format 7 on) */
  bool verify_gain_mode;

  /* Derived per stage (not saved: recomputed from the configuration). */
  /* lo_k, hi_k: each entry's box; move_lo_k, move_hi_k: the range its
   * iterates move in (the box widened by HETINV_OPTIMIZER_BOX_MARGIN). */
  double *scale, *lo_k, *hi_k, *move_lo_k, *move_hi_k, *grad;
  double *multiscale; /* the multi-scale step's block sums (2k doubles) */
  /* Entries that step together (methods.c): reduced coordinates pair each
   * free σs entry (first) with its cell's free g entry (second), mean-ratio
   * coordinates each free σa entry with its cell's free σs entry.
   * pair_second[i]: the second entry of first entry i (else -1);
   * pair_first[j]: the first entry of second entry j (else -1). */
  int64_t *pair_second, *pair_first;
};

/* optimizer.c */
/* Entry i's box allows steps in ln π: 0 < lo < hi < ∞. */
static inline bool hv_entry_log_box(const hetinv_optimizer_t *opt, size_t i) {
  double lo = opt->lo_k[i], hi = opt->hi_k[i];
  return lo > 0.0 && hi > lo && hi < HUGE_VAL;
}
/* The first iteration of the stage's settling part (the stage's iteration
 * count when it has none). Resolved iterations only. */
static inline int64_t hv_stage_settle_from(const hv_stage_t *st) {
  if (st->settle_fraction == 0.0) return st->iterations;
  return st->iterations - (int64_t)llround(st->settle_fraction * (double)st->iterations);
}
/* "HETINV_OPTIMIZER_DECAY", ..., for messages. */
const char *hv_optimizer_param_name(hetinv_optimizer_param_t param);
hetinv_result_t hv_optimizer_begin_stage(hetinv_optimizer_t *opt);
void hv_optimizer_free_stage_arrays(hetinv_optimizer_t *opt);
hetinv_result_t hv_optimizer_alloc_stage_arrays(hetinv_optimizer_t *opt, size_t k);
void hv_optimizer_stage_bounds(hetinv_optimizer_t *opt);
void hv_optimizer_resolve_iterations(hetinv_optimizer_t *opt);
void hv_optimizer_average(const hetinv_optimizer_t *opt, double *out);

/* minibatch.c */
hetinv_result_t hv_emitter_groups_build(const hetinv_context_t *ctx,
                                        const hetinv_measurements_t *set,
                                        hv_emitter_groups_t *groups);
void hv_emitter_groups_release(const hetinv_context_t *ctx, hv_emitter_groups_t *groups);
/* Picks `size` distinct groups for iteration `iteration` (sorted ascending). */
void hv_minibatch_pick(uint64_t seed, int64_t iteration, int32_t groups, int32_t size,
                       int32_t *picked, int32_t *scratch);
/* A new set with the rows of the picked groups, their measured values,
 * weights and mask (ANDed with value_mask when not NULL). */
hetinv_result_t hv_minibatch_set(const hetinv_optimizer_t *opt, const int32_t *picked,
                                 int32_t count, const uint8_t *value_mask,
                                 hetinv_measurements_t **out);

/* methods.c: one step of the optimizer's method on the stage's entries,
 * ADADELTA's ε given (hv_stage_epsilon; the other methods' step size
 * follows it relative to the tunable ε); returns the RMS of the step
 * relative to the scales. */
double hv_method_step(hetinv_optimizer_t *opt, const uint8_t *frozen, double epsilon);
/* ADADELTA's ε at the current iteration of the current stage. */
double hv_stage_epsilon(const hetinv_optimizer_t *opt);

/* smoothness.c: adds the smoothness prior's gradient at π (the current
 * stage's entries, on its map) to grad and returns the prior's value; 0
 * and grad untouched when HETINV_OPTIMIZER_SMOOTHNESS is 0. */
double hv_smoothness_add(const hetinv_optimizer_t *opt, const hetinv_param_map_t *map,
                         const double *pi, double *grad);

/* multiscale.c: adds to opt->grad the multi-scale step's block means (the
 * current stage's entries, on its map; entries frozen in `frozen`, which
 * may be NULL, left out); nothing when HETINV_OPTIMIZER_MULTISCALE is 0. */
void hv_multiscale_apply(hetinv_optimizer_t *opt, const hetinv_param_map_t *map, const uint8_t *frozen);

/* checkpoint.c */
hetinv_result_t hv_checkpoint_write(const hetinv_optimizer_t *opt, const char *path);

#endif
