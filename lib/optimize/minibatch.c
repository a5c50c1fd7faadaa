/* Minibatches of emitters: the set's rows grouped by emitter, a
 * reproducible draw of groups per iteration, and the sub-set it renders. */
#include <stdlib.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "core/rng.h"
#include "optimize/optimizer_internal.h"
#include "sampling/measurements_internal.h"

/* Keeps minibatch draws apart from photon streams, whose emitter keys are
 * small plan indices. */
#define HV_MINIBATCH_KEY UINT32_C(0xFFFFFF01)

hetinv_result_t hv_emitter_groups_build(const hetinv_context_t *ctx,
                                        const hetinv_measurements_t *set,
                                        hv_emitter_groups_t *groups) {
  int32_t rows = set->row_count;
  int32_t *group_of = hv_calloc(ctx, (size_t)rows, sizeof(int32_t));
  const hetinv_emitter_t **first = hv_calloc(ctx, (size_t)rows, sizeof *first);
  int32_t *cursor = hv_calloc(ctx, (size_t)rows, sizeof(int32_t));
  groups->start = hv_calloc(ctx, (size_t)rows + 1, sizeof(int32_t));
  groups->rows = hv_calloc(ctx, (size_t)rows, sizeof(int32_t));
  bool ok = group_of && first && cursor && groups->start && groups->rows;
  int32_t count = 0;
  /* Groups in order of first use, as the estimator orders its emitters.
   * Quadratic in the emitter count, which stays in the thousands. */
  for (int32_t r = 0; ok && r < rows; ++r) {
    int32_t g = 0;
    while (g < count && first[g] != set->rows[r].emitter) ++g;
    if (g == count) first[count++] = set->rows[r].emitter;
    group_of[r] = g;
  }
  if (ok) {
    for (int32_t r = 0; r < rows; ++r) ++groups->start[group_of[r] + 1];
    for (int32_t g = 0; g < count; ++g) groups->start[g + 1] += groups->start[g];
    for (int32_t g = 0; g < count; ++g) cursor[g] = groups->start[g];
    for (int32_t r = 0; r < rows; ++r) groups->rows[cursor[group_of[r]]++] = r;
  }
  hv_free(ctx, group_of);
  hv_free(ctx, first);
  hv_free(ctx, cursor);
  if (!ok) {
    hv_emitter_groups_release(ctx, groups);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot group %d rows by emitter", (int)rows);
  }
  groups->count = count;
  return HETINV_SUCCESS;
}

void hv_emitter_groups_release(const hetinv_context_t *ctx, hv_emitter_groups_t *groups) {
  hv_free(ctx, groups->start);
  hv_free(ctx, groups->rows);
  groups->start = groups->rows = NULL;
  groups->count = 0;
}

/* Uniform integer in [0, n) without modulo bias (Lemire 2019). */
static uint32_t uniform_below(hv_rng_t *rng, uint32_t n) {
  uint64_t m = (uint64_t)hv_rng_u32(rng) * n;
  uint32_t low = (uint32_t)m;
  if (low < n) {
    uint32_t threshold = (uint32_t)(-n) % n;
    while (low < threshold) {
      m = (uint64_t)hv_rng_u32(rng) * n;
      low = (uint32_t)m;
    }
  }
  return (uint32_t)(m >> 32);
}

static int compare_i32(const void *a, const void *b) {
  int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
  return (x > y) - (x < y);
}

void hv_minibatch_pick(uint64_t seed, int64_t iteration, int32_t groups, int32_t size,
                       int32_t *picked, int32_t *scratch) {
  if (size >= groups) {
    for (int32_t g = 0; g < groups; ++g) picked[g] = g;
    return;
  }
  /* Partial Fisher–Yates shuffle of [0, groups) on a stream of its own. */
  hv_rng_t rng = hv_rng_init(seed, HV_MINIBATCH_KEY,
                             (uint64_t)iteration & (HV_RNG_PHOTON_LIMIT - 1), 0);
  for (int32_t g = 0; g < groups; ++g) scratch[g] = g;
  for (int32_t i = 0; i < size; ++i) {
    int32_t j = i + (int32_t)uniform_below(&rng, (uint32_t)(groups - i));
    int32_t t = scratch[i];
    scratch[i] = scratch[j];
    scratch[j] = t;
    picked[i] = scratch[i];
  }
  qsort(picked, (size_t)size, sizeof *picked, compare_i32);
}

hetinv_result_t hv_minibatch_set(const hetinv_optimizer_t *opt, const int32_t *picked,
                                 int32_t count, const uint8_t *value_mask,
                                 hetinv_measurements_t **out) {
  const hetinv_measurements_t *set = opt->set;
  const hv_emitter_groups_t *groups = &opt->groups;
  hetinv_measurements_t *sub = NULL;
  hetinv_result_t r = hetinv_measurements_create(opt->ctx, &sub);
  for (int32_t i = 0; r == HETINV_SUCCESS && i < count; ++i) {
    for (int32_t j = groups->start[picked[i]]; r == HETINV_SUCCESS && j < groups->start[picked[i] + 1]; ++j) {
      const hv_row_t *row = &set->rows[groups->rows[j]];
      r = hetinv_measurements_add(sub, row->emitter, row->sensor, row->pathlength, NULL);
    }
  }
  size_t n = r == HETINV_SUCCESS ? sub->value_count : 0;
  if (r == HETINV_SUCCESS) {
    /* Copy each row's values into the sub-set's layout. */
    size_t at = 0;
    for (int32_t i = 0; i < count; ++i) {
      for (int32_t j = groups->start[picked[i]]; j < groups->start[picked[i] + 1]; ++j) {
        const hv_row_t *row = &set->rows[groups->rows[j]];
        size_t len = (size_t)row->pixels * (size_t)row->bins;
        memcpy(sub->values + at, set->values + row->offset, len * sizeof(double));
        memcpy(sub->std_errors + at, set->std_errors + row->offset, len * sizeof(double));
        memcpy(sub->weights + at, set->weights + row->offset, len * sizeof(double));
        memcpy(sub->clip_below + at, set->clip_below + row->offset, len * sizeof(double));
        memcpy(sub->clip_above + at, set->clip_above + row->offset, len * sizeof(double));
        for (size_t v = 0; v < len; ++v) {
          bool keep = set->mask[row->offset + v] && (value_mask == NULL || value_mask[row->offset + v]);
          sub->mask[at + v] = keep ? 1 : 0;
        }
        at += len;
      }
    }
    if (at != n) r = HV_FAIL(opt->ctx, HETINV_ERROR_INTERNAL, "minibatch layout mismatch");
  }
  if (r != HETINV_SUCCESS) {
    hetinv_measurements_destroy(&sub);
    return r;
  }
  *out = sub;
  return HETINV_SUCCESS;
}
