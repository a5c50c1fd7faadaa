/* The optimizer's configuration (tunables, bounds, stages) and its
 * per-stage arrays; the iteration loop is in run.c. */
#include <math.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "optimize/optimizer_internal.h"
#include "param/param_map_internal.h"
#include "sampling/measurements_internal.h"

typedef struct param_info {
  double def, lo, hi;
  bool integer;
  const char *name;
} param_info_t;

static const param_info_t PARAMS[HETINV_OPTIMIZER_PARAM_COUNT_] = {
    [HETINV_OPTIMIZER_METHOD] = {HETINV_METHOD_ADADELTA, 0, HETINV_METHOD_COUNT_ - 1, true, "HETINV_OPTIMIZER_METHOD"},
    [HETINV_OPTIMIZER_DECAY] = {0.95, 0, 0.999999, false, "HETINV_OPTIMIZER_DECAY"},
    [HETINV_OPTIMIZER_EPSILON] = {0.01, 1e-12, 1, false, "HETINV_OPTIMIZER_EPSILON"},
    [HETINV_OPTIMIZER_LEARNING_RATE] = {0.01, 1e-300, 1e12, false, "HETINV_OPTIMIZER_LEARNING_RATE"},
    [HETINV_OPTIMIZER_BETA1] = {0.9, 0, 0.999999, false, "HETINV_OPTIMIZER_BETA1"},
    [HETINV_OPTIMIZER_BETA2] = {0.999, 0, 0.999999, false, "HETINV_OPTIMIZER_BETA2"},
    [HETINV_OPTIMIZER_MINIBATCH] = {0, 0, 2147483647.0, true, "HETINV_OPTIMIZER_MINIBATCH"},
    [HETINV_OPTIMIZER_ITERATIONS] = {100, 1, 1e15, true, "HETINV_OPTIMIZER_ITERATIONS"},
    [HETINV_OPTIMIZER_TIME_BUDGET] = {0, 0, 1e12, false, "HETINV_OPTIMIZER_TIME_BUDGET"},
    [HETINV_OPTIMIZER_PLATEAU_WINDOW] = {0, 0, 1e9, true, "HETINV_OPTIMIZER_PLATEAU_WINDOW"},
    [HETINV_OPTIMIZER_PLATEAU_TOLERANCE] = {0.01, 0, 1, false, "HETINV_OPTIMIZER_PLATEAU_TOLERANCE"},
    [HETINV_OPTIMIZER_AVERAGE_WINDOW] = {20, 1, 4096, true, "HETINV_OPTIMIZER_AVERAGE_WINDOW"},
    [HETINV_OPTIMIZER_CHECKPOINT_INTERVAL] = {10, 1, 1e15, true, "HETINV_OPTIMIZER_CHECKPOINT_INTERVAL"},
    [HETINV_OPTIMIZER_COORDINATES] = {HETINV_COORDINATES_NATIVE, 0, HETINV_COORDINATES_COUNT_ - 1, true, "HETINV_OPTIMIZER_COORDINATES"},
    [HETINV_OPTIMIZER_SMOOTHNESS] = {0, 0, 1e12, false, "HETINV_OPTIMIZER_SMOOTHNESS"},
    [HETINV_OPTIMIZER_MULTISCALE] = {0, 0, 100, false, "HETINV_OPTIMIZER_MULTISCALE"},
    [HETINV_OPTIMIZER_BOX_MARGIN] = {0, 0, 1, false, "HETINV_OPTIMIZER_BOX_MARGIN"},
};

const char *hv_optimizer_param_name(hetinv_optimizer_param_t param) {
  return param >= 0 && param < HETINV_OPTIMIZER_PARAM_COUNT_ ? PARAMS[param].name : "an unknown tunable";
}

HETINV_API hetinv_result_t hetinv_optimizer_create(hetinv_context_t *ctx,
                                                   const hetinv_measurements_t *set,
                                                   const hetinv_medium_t *initial,
                                                   hetinv_optimizer_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(ctx, out);
  *out = NULL;
  HV_CHECK_NULL(ctx, ctx);
  HV_CHECK_NULL(ctx, set);
  HV_CHECK_NULL(ctx, initial);
  if (hetinv_measurements_row_count(set) == 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "the measurement set has no rows");
  }
  /* Here, not at the run's first render. */
  hetinv_result_t r = hv_measurements_check_medium(ctx, set, initial);
  if (r != HETINV_SUCCESS) return r;
  hetinv_optimizer_t *opt = hv_calloc(ctx, 1, sizeof *opt);
  if (opt == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the optimizer");
  opt->ctx = ctx;
  opt->set = set;
  for (int p = 0; p < HETINV_OPTIMIZER_PARAM_COUNT_; ++p) opt->param[p] = PARAMS[p].def;
  opt->lo[HETINV_PARAM_SIGMA_A] = opt->lo[HETINV_PARAM_SIGMA_S] = 0.0;
  opt->hi[HETINV_PARAM_SIGMA_A] = opt->hi[HETINV_PARAM_SIGMA_S] = (double)INFINITY;
  opt->lo[HETINV_PARAM_G] = -0.99;
  opt->hi[HETINV_PARAM_G] = 0.99;
  r = hetinv_medium_clone(initial, &opt->initial);
  if (r == HETINV_SUCCESS) r = hetinv_medium_commit(opt->initial);
  if (r == HETINV_SUCCESS) r = hv_emitter_groups_build(ctx, set, &opt->groups);
  if (r != HETINV_SUCCESS) {
    hetinv_optimizer_destroy(&opt);
    return r;
  }
  *out = opt;
  return HETINV_SUCCESS;
}

void hv_optimizer_free_stage_arrays(hetinv_optimizer_t *opt) {
  const hetinv_context_t *ctx = opt->ctx;
  double **arrays[] = {&opt->pi, &opt->acc1, &opt->acc2, &opt->ring,
                       &opt->scale, &opt->lo_k, &opt->hi_k, &opt->move_lo_k, &opt->move_hi_k,
                       &opt->grad, &opt->multiscale};
  for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i) {
    hv_free(ctx, *arrays[i]);
    *arrays[i] = NULL;
  }
  hv_free(ctx, opt->pair_second);
  hv_free(ctx, opt->pair_first);
  opt->pair_second = opt->pair_first = NULL;
  opt->k = 0;
  opt->ring_count = opt->ring_head = 0;
}

HETINV_API void hetinv_optimizer_destroy(hetinv_optimizer_t **optimizer) {
  HV_API_ENTER();
  if (optimizer == NULL || *optimizer == NULL) return;
  hetinv_optimizer_t *opt = *optimizer;
  const hetinv_context_t *ctx = opt->ctx;
  hv_optimizer_free_stage_arrays(opt);
  for (int32_t s = 0; s < opt->stage_count; ++s) {
    hv_free(ctx, opt->stages[s].frozen);
    hv_free(ctx, opt->stages[s].value_mask);
  }
  hv_free(ctx, opt->stages);
  hv_free(ctx, opt->checkpoint_path);
  hv_free(ctx, opt->losses);
  hv_emitter_groups_release(ctx, &opt->groups);
  hetinv_medium_destroy(&opt->initial);
  hetinv_medium_destroy(&opt->base);
  hv_free(ctx, opt);
  *optimizer = NULL;
}

HETINV_API hetinv_result_t hetinv_optimizer_param_bounds(hetinv_optimizer_param_t param,
                                                         double *lo, double *hi) {
  HV_API_ENTER();
  if (param < 0 || param >= HETINV_OPTIMIZER_PARAM_COUNT_) {
    return HV_FAIL(NULL, HETINV_ERROR_OUT_OF_RANGE, "unknown optimizer parameter %d", (int)param);
  }
  if (lo) *lo = PARAMS[param].lo;
  if (hi) *hi = PARAMS[param].hi;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_optimizer_set_param(hetinv_optimizer_t *optimizer,
                                                      hetinv_optimizer_param_t param, double value) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  const hetinv_context_t *ctx = optimizer->ctx;
  if (param < 0 || param >= HETINV_OPTIMIZER_PARAM_COUNT_) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_RANGE, "unknown optimizer parameter %d", (int)param);
  }
  const param_info_t *info = &PARAMS[param];
  if (!(value >= info->lo && value <= info->hi) || (info->integer && value != floor(value))) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "%s is %.15g; it must be %s in [%.15g, %.15g]",
                   info->name, value, info->integer ? "an integer" : "a number", info->lo, info->hi);
  }
  if (optimizer->started) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE,
                   "cannot change %s: the run has started (a resumed run must keep its settings)",
                   info->name);
  }
  optimizer->param[param] = value;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_optimizer_get_param(const hetinv_optimizer_t *optimizer,
                                                      hetinv_optimizer_param_t param,
                                                      double *value) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  HV_CHECK_NULL(optimizer->ctx, value);
  if (param < 0 || param >= HETINV_OPTIMIZER_PARAM_COUNT_) {
    return HV_FAIL(optimizer->ctx, HETINV_ERROR_OUT_OF_RANGE, "unknown optimizer parameter %d",
                   (int)param);
  }
  *value = optimizer->param[param];
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_optimizer_set_bounds(hetinv_optimizer_t *optimizer,
                                                       hetinv_param_t param, double lo, double hi) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  const hetinv_context_t *ctx = optimizer->ctx;
  if (param < 0 || param >= HETINV_PARAM_COUNT) {
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_RANGE, "unknown parameter %d", (int)param);
  }
  const char *name = hetinv_param_name(param);
  bool sigma = param != HETINV_PARAM_G;
  bool ok = !isnan(lo) && !isnan(hi) && lo < hi &&
            (sigma ? lo >= 0.0 && isfinite(lo) : lo > -1.0 && hi < 1.0);
  if (!ok) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "bounds [%g, %g] of %s: they need lo < hi %s", lo, hi, name,
                   sigma ? "and 0 <= lo < +inf" : "inside (-1, 1)");
  }
  /* A finite box is the entries' scale s, and the methods square it
   * (ADADELTA's (ε·s)², SGD's s²): wider, their steps overflow to inf. */
  if (isfinite(hi) && hi - lo > HETINV_OPTIMIZER_MAX_BOX_WIDTH) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "bounds [%g, %g] of %s: a finite box at most %g wide (the steps' scale); +inf for no upper bound",
                   lo, hi, name, HETINV_OPTIMIZER_MAX_BOX_WIDTH);
  }
  if (optimizer->started) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE, "cannot change the bounds of %s: the run has started", name);
  }
  optimizer->lo[param] = lo;
  optimizer->hi[param] = hi;
  return HETINV_SUCCESS;
}

/* A copy of n bytes, or NULL for NULL; *failed on allocation failure. */
static uint8_t *copy_bytes(const hetinv_context_t *ctx, const uint8_t *src, size_t n, bool *failed) {
  if (src == NULL || n == 0) return NULL;
  uint8_t *dst = hv_alloc(ctx, n);
  if (dst == NULL) {
    *failed = true;
    return NULL;
  }
  memcpy(dst, src, n);
  return dst;
}

HETINV_API hetinv_result_t hetinv_optimizer_add_stage(hetinv_optimizer_t *optimizer,
                                                      const hetinv_stage_t *stage) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  const hetinv_context_t *ctx = optimizer->ctx;
  HV_CHECK_NULL(ctx, stage);
  if (stage->size != HETINV_STAGE_SIZE_V1 && stage->size != HETINV_STAGE_SIZE_V2 &&
      stage->size != HETINV_STAGE_SIZE_V3 && stage->size != sizeof(hetinv_stage_t)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "stage->size is %zu; it must be sizeof(hetinv_stage_t) = %zu (or %zu, %zu or %zu, the earlier "
                   "versions')",
                   stage->size, sizeof(hetinv_stage_t), (size_t)HETINV_STAGE_SIZE_V1,
                   (size_t)HETINV_STAGE_SIZE_V2, (size_t)HETINV_STAGE_SIZE_V3);
  }
  /* Members past the caller's size read as 0. */
  const bool v2 = stage->size >= HETINV_STAGE_SIZE_V2, v3 = stage->size >= HETINV_STAGE_SIZE_V3,
             v4 = stage->size == sizeof(hetinv_stage_t);
  const double epsilon_start = v2 ? stage->epsilon_start : 0.0;
  const int32_t average_window = v2 ? stage->average_window : 0;
  const double settle_epsilon = v3 ? stage->settle_epsilon : 0.0;
  const double settle_fraction = v3 ? stage->settle_fraction : 0.0;
  const double settle_photons = v4 ? stage->settle_photons : 0.0;
  if (average_window < 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "stage %d: average_window is %d; it must be >= 0",
                   (int)optimizer->stage_count, (int)average_window);
  }
  if (!(epsilon_start == 0.0 || (epsilon_start >= 1e-12 && epsilon_start <= 1.0))) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "stage %d: epsilon_start is %g; it must be 0 or in [1e-12, 1]",
                   (int)optimizer->stage_count, epsilon_start);
  }
  if (!(settle_epsilon == 0.0 || (settle_epsilon >= 1e-12 && settle_epsilon <= 1.0))) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "stage %d: settle_epsilon is %g; it must be 0 or in [1e-12, 1]",
                   (int)optimizer->stage_count, settle_epsilon);
  }
  if (!(settle_photons == 0.0 || (settle_photons >= 1.0 && settle_photons <= 1e6))) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "stage %d: settle_photons is %g; it must be 0 or in [1, 1e6]",
                   (int)optimizer->stage_count, settle_photons);
  }
  const bool settles = settle_epsilon != 0.0 || settle_photons != 0.0;
  if (!settles ? settle_fraction != 0.0 : !(settle_fraction > 0.0 && settle_fraction < 1.0)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "stage %d: settle_fraction is %g; it must be in (0, 1) with a settle_epsilon or settle_photons, "
                   "0 without (settle_epsilon is %g, settle_photons %g)",
                   (int)optimizer->stage_count, settle_fraction, settle_epsilon, settle_photons);
  }
  if (stage->map == NULL) return HV_FAIL(ctx, HETINV_ERROR_NULL_ARGUMENT, "'stage->map' is NULL");
  if (!hv_param_map_fits(stage->map, optimizer->initial)) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "stage %d: its map was made for another grid than the initial medium's",
                   (int)optimizer->stage_count);
  }
  if (stage->iterations < 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "stage %d: iterations is %d; it must be >= 0",
                   (int)optimizer->stage_count, (int)stage->iterations);
  }
  if (optimizer->started) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE, "cannot add a stage: the run has started");
  }
  if (optimizer->stage_count >= HETINV_MAX_STAGES) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "the schedule already has %d stages, HETINV_MAX_STAGES", (int)optimizer->stage_count);
  }
  if (optimizer->stage_count == optimizer->stage_capacity) {
    int32_t cap = optimizer->stage_capacity ? 2 * optimizer->stage_capacity : 4;
    hv_stage_t *grown = hv_calloc(ctx, (size_t)cap, sizeof *grown);
    if (grown == NULL) return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot grow the schedule");
    if (optimizer->stage_count) memcpy(grown, optimizer->stages, (size_t)optimizer->stage_count * sizeof *grown);
    hv_free(ctx, optimizer->stages);
    optimizer->stages = grown;
    optimizer->stage_capacity = cap;
  }
  hv_stage_t s = {.map = stage->map, .k = hetinv_param_map_size(stage->map), .requested = stage->iterations,
                  .epsilon_start = epsilon_start, .average_window = average_window,
                  .settle_epsilon = settle_epsilon, .settle_fraction = settle_fraction,
                  .settle_photons = settle_photons};
  bool failed = false;
  s.frozen = copy_bytes(ctx, stage->frozen, s.k, &failed);
  s.value_mask = copy_bytes(ctx, stage->value_mask, hetinv_measurements_value_count(optimizer->set), &failed);
  if (failed) {
    hv_free(ctx, s.frozen);
    hv_free(ctx, s.value_mask);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot copy the stage's masks");
  }
  optimizer->stages[optimizer->stage_count++] = s;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_optimizer_set_progress(hetinv_optimizer_t *optimizer,
                                                         hetinv_progress_fn fn, void *user) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  optimizer->progress = fn;
  optimizer->user = user;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_optimizer_set_checkpoint(hetinv_optimizer_t *optimizer,
                                                           const char *path) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  char *copy = NULL;
  if (path != NULL && path[0] == '\0') { /* else refused only after the run's first iterations */
    return HV_FAIL(optimizer->ctx, HETINV_ERROR_INVALID_ARGUMENT, "the checkpoint path is empty (NULL stops checkpoints)");
  }
  if (path != NULL) {
    copy = hv_strdup(optimizer->ctx, path);
    if (copy == NULL) return HV_FAIL(optimizer->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot copy the path");
  }
  hv_free(optimizer->ctx, optimizer->checkpoint_path);
  optimizer->checkpoint_path = copy;
  return HETINV_SUCCESS;
}

void hv_optimizer_resolve_iterations(hetinv_optimizer_t *opt) {
  for (int32_t s = 0; s < opt->stage_count; ++s) {
    hv_stage_t *st = &opt->stages[s];
    st->iterations = st->requested > 0 ? st->requested : (int64_t)opt->param[HETINV_OPTIMIZER_ITERATIONS];
  }
}

static void pair_cells(hetinv_optimizer_t *opt);

hetinv_result_t hv_optimizer_alloc_stage_arrays(hetinv_optimizer_t *opt, size_t k) {
  const hetinv_context_t *ctx = opt->ctx;
  /* Allocated before the old state is released, so that a failure leaves
   * the optimizer as it was (a failed stage change can then be retried). */
  int32_t window = (int32_t)opt->param[HETINV_OPTIMIZER_AVERAGE_WINDOW];
  enum { VECTORS = 10 };
  double *v[VECTORS + 1];
  bool ok = true;
  for (int i = 0; i < VECTORS; ++i) {
    /* The multi-scale step's block sums: fewer than 2k (multiscale.c). */
    v[i] = hv_calloc(ctx, i == 7 ? 2 * k : k, sizeof(double));
    ok = ok && v[i] != NULL;
  }
  size_t ring_len;
  v[VECTORS] = hv_mul_size(k, (size_t)window, &ring_len) ? hv_calloc(ctx, ring_len, sizeof(double)) : NULL;
  int64_t *pairs[2] = {hv_calloc(ctx, k, sizeof(int64_t)), hv_calloc(ctx, k, sizeof(int64_t))};
  if (!ok || v[VECTORS] == NULL || pairs[0] == NULL || pairs[1] == NULL) {
    for (int i = 0; i <= VECTORS; ++i) hv_free(ctx, v[i]);
    hv_free(ctx, pairs[0]);
    hv_free(ctx, pairs[1]);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the state of %zu entries", k);
  }
  hv_optimizer_free_stage_arrays(opt);
  opt->window = window;
  opt->pi = v[0], opt->acc1 = v[1], opt->acc2 = v[2], opt->scale = v[3];
  opt->lo_k = v[4], opt->hi_k = v[5], opt->grad = v[6], opt->multiscale = v[7], opt->ring = v[VECTORS];
  opt->move_lo_k = v[8], opt->move_hi_k = v[9];
  opt->pair_second = pairs[0], opt->pair_first = pairs[1];
  opt->k = k;
  hv_optimizer_stage_bounds(opt);
  pair_cells(opt);
  return HETINV_SUCCESS;
}

/* The pairs of entries that step together (optimizer_internal.h): the
 * free `first` entry of each cell and the free `second` entry of the same
 * cell. pair_first first serves as the table cell -> first entry (a block
 * has one entry per cell, so its cells are < k). */
static void pair_cells(hetinv_optimizer_t *opt) {
  const hv_stage_t *st = &opt->stages[opt->stage];
  size_t k = opt->k;
  int c = (int)opt->param[HETINV_OPTIMIZER_COORDINATES];
  bool mean_ratio = c == HETINV_COORDINATES_LOG_MEAN_RATIO;
  hetinv_param_t first = mean_ratio ? HETINV_PARAM_SIGMA_A : HETINV_PARAM_SIGMA_S;
  hetinv_param_t second = mean_ratio ? HETINV_PARAM_SIGMA_S : HETINV_PARAM_G;
  int64_t *by_cell = opt->pair_first;
  for (size_t i = 0; i < k; ++i) opt->pair_second[i] = by_cell[i] = -1;
  for (size_t i = 0; i < k; ++i) {
    hetinv_param_t p = HETINV_PARAM_SIGMA_A;
    size_t cell = 0;
    hetinv_param_map_entry(st->map, i, &p, &cell);
    bool logs = !mean_ratio || hv_entry_log_box(opt, i); /* mean-ratio steps are in logs */
    if (p == first && cell < k && logs && !(st->frozen && st->frozen[i])) by_cell[cell] = (int64_t)i;
  }
  for (size_t j = 0; j < k; ++j) {
    hetinv_param_t p = HETINV_PARAM_SIGMA_A;
    size_t cell = 0;
    hetinv_param_map_entry(st->map, j, &p, &cell);
    bool logs = !mean_ratio || hv_entry_log_box(opt, j);
    if (p == second && cell < k && logs && by_cell[cell] >= 0 && !(st->frozen && st->frozen[j])) {
      opt->pair_second[by_cell[cell]] = (int64_t)j;
    }
  }
  for (size_t i = 0; i < k; ++i) by_cell[i] = -1;
  for (size_t i = 0; i < k; ++i) {
    if (opt->pair_second[i] >= 0) by_cell[opt->pair_second[i]] = (int64_t)i;
  }
}

/* The range entry i's iterates move in: its box widened by
 * HETINV_OPTIMIZER_BOX_MARGIN (in ln π where the entry moves in it, as
 * methods.c's log_scale decides), within the parameter's physical range. */
static void move_range(const hetinv_optimizer_t *opt, hetinv_param_t p, size_t i, double *lo, double *hi) {
  double m = opt->param[HETINV_OPTIMIZER_BOX_MARGIN], a = opt->lo_k[i], b = opt->hi_k[i];
  *lo = a;
  *hi = b;
  if (m == 0.0) return;
  int c = (int)opt->param[HETINV_OPTIMIZER_COORDINATES];
  bool logs = (c == HETINV_COORDINATES_LOG || c == HETINV_COORDINATES_LOG_REDUCED ||
               c == HETINV_COORDINATES_LOG_MEAN_RATIO) &&
              hv_entry_log_box(opt, i);
  if (logs) {
    double f = pow(b / a, m);
    *lo = a / f;
    *hi = b * f;
  } else if (isfinite(b)) {
    *lo = a - m * (b - a);
    *hi = b + m * (b - a);
  }
  if (p == HETINV_PARAM_G) { /* never narrower than the box, which may reach past ±0.99 */
    *lo = fmax(*lo, fmin(a, -0.99));
    *hi = fmin(*hi, fmax(b, 0.99));
  } else {
    *lo = fmax(*lo, 0.0);
  }
}

/* Each entry's box, the range its iterates move in, and its scale, from
 * its parameter's bounds. */
void hv_optimizer_stage_bounds(hetinv_optimizer_t *opt) {
  const hetinv_param_map_t *map = opt->stages[opt->stage].map;
  for (size_t i = 0; i < opt->k; ++i) {
    hetinv_param_t p = HETINV_PARAM_SIGMA_A;
    hetinv_param_map_entry(map, i, &p, NULL);
    opt->lo_k[i] = opt->lo[p];
    opt->hi_k[i] = opt->hi[p];
    move_range(opt, p, i, &opt->move_lo_k[i], &opt->move_hi_k[i]);
    double width = opt->hi[p] - opt->lo[p];
    opt->scale[i] = isfinite(width) ? width : 1.0;
  }
}

/* Starts stage opt->stage: π from the base medium, projected on the box. */
hetinv_result_t hv_optimizer_begin_stage(hetinv_optimizer_t *opt) {
  const hv_stage_t *st = &opt->stages[opt->stage];
  hetinv_result_t r = hv_optimizer_alloc_stage_arrays(opt, st->k);
  if (r != HETINV_SUCCESS) return r;
  r = hetinv_param_map_extract(st->map, opt->base, opt->pi, opt->k);
  if (r != HETINV_SUCCESS) return r;
  for (size_t i = 0; i < opt->k; ++i) opt->pi[i] = fmin(fmax(opt->pi[i], opt->move_lo_k[i]), opt->move_hi_k[i]);
  return HETINV_SUCCESS;
}

/* Mean of the stage's window of most recent iterates in the ring, oldest
 * first (a fixed order), projected onto the box (the iterates may have
 * left it by HETINV_OPTIMIZER_BOX_MARGIN). */
void hv_optimizer_average(const hetinv_optimizer_t *opt, double *out) {
  size_t k = opt->k;
  int32_t count = opt->ring_count;
  int64_t stage_window = 0;
  if (opt->stage < opt->stage_count) {
    const hv_stage_t *st = &opt->stages[opt->stage];
    stage_window = st->average_window;
    /* Window 0 with a settling part: that part's iterates (int64_t: a
     * stage may run more than 2^31 iterations). */
    if (stage_window == 0) stage_window = st->iterations - hv_stage_settle_from(st);
  }
  if (stage_window > 0 && stage_window < count) count = (int32_t)stage_window;
  if (count == 0) {
    memcpy(out, opt->pi, k * sizeof(double));
  } else {
    for (size_t i = 0; i < k; ++i) out[i] = 0.0;
    int32_t oldest = (opt->ring_head - count + opt->window) % opt->window;
    for (int32_t j = 0; j < count; ++j) {
      const double *it = opt->ring + (size_t)((oldest + j) % opt->window) * k;
      for (size_t i = 0; i < k; ++i) out[i] += it[i];
    }
    for (size_t i = 0; i < k; ++i) out[i] /= count;
  }
  for (size_t i = 0; i < k; ++i) out[i] = fmin(fmax(out[i], opt->lo_k[i]), opt->hi_k[i]);
}

HETINV_API hetinv_result_t hetinv_optimizer_get_pi(const hetinv_optimizer_t *optimizer,
                                                   int averaged, double *pi, size_t count) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  const hetinv_context_t *ctx = optimizer->ctx;
  HV_CHECK_NULL(ctx, pi);
  if (optimizer->k == 0) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE, "no stage has started: run the optimizer first");
  }
  if (count != optimizer->k) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "count is %zu; the current stage has %zu entries",
                   count, optimizer->k);
  }
  if (averaged) {
    hv_optimizer_average(optimizer, pi);
  } else {
    memcpy(pi, optimizer->pi, count * sizeof(double));
  }
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_optimizer_result(const hetinv_optimizer_t *optimizer,
                                                   hetinv_medium_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(optimizer ? optimizer->ctx : NULL, out);
  *out = NULL; /* before the other checks: a failed call never leaves the caller's old handle */
  HV_CHECK_NULL(NULL, optimizer);
  const hetinv_context_t *ctx = optimizer->ctx;
  hetinv_medium_t *m = NULL;
  hetinv_result_t r = hetinv_medium_clone(optimizer->base ? optimizer->base : optimizer->initial, &m);
  if (r == HETINV_SUCCESS && optimizer->k > 0) {
    double *avg = hv_calloc(ctx, optimizer->k, sizeof(double));
    if (avg == NULL) {
      r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu entries", optimizer->k);
    } else {
      hv_optimizer_average(optimizer, avg);
      r = hetinv_param_map_apply(optimizer->stages[optimizer->stage].map, avg, optimizer->k, m);
      hv_free(ctx, avg);
    }
  }
  if (r == HETINV_SUCCESS) r = hetinv_medium_commit(m);
  if (r != HETINV_SUCCESS) {
    hetinv_medium_destroy(&m);
    return r;
  }
  *out = m;
  return HETINV_SUCCESS;
}

HETINV_API const double *hetinv_optimizer_losses(const hetinv_optimizer_t *optimizer, size_t *count) {
  HV_API_ENTER();
  if (count) *count = optimizer ? optimizer->loss_count : 0;
  return optimizer && optimizer->loss_count ? optimizer->losses : NULL;
}
