/* Checkpoints: the optimizer's whole run state in one binary file, written
 * atomically (here; checkpoint_read.c reads and validates them), with a
 * fingerprint of the configuration that produced it (so a resume into a
 * different problem is refused, naming the difference) and a checksum (so
 * a damaged file is refused).
 *
 * Layout, little-endian host order, every field 8 bytes:
 *   "HVCKPT01", byte-order tag, format version,
 *   fingerprint: value count, rows, emitters, stages and per stage
 *     (entries, iterations, hash of its masks), the tunables, the bounds,
 *     the estimator's tunables, hash of the set's values, hash of the
 *     initial medium, context seed, hash of the set's geometry
 *     (estimator/set_hash.h), the estimator's gain mode;
 *   state: stage, stage iteration, iteration, elapsed, entries, π and two
 *     accumulators, window, ring count and head, ring, loss count and
 *     losses, the base medium's three grids;
 *   FNV-1a 64 of everything before (a check against damage only: the
 *   reader validates every field against the configuration). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "estimator/set_hash.h"
#include "optimize/checkpoint_internal.h"
#include "optimize/optimizer_internal.h"
#include "sampling/measurements_internal.h"

/* --- a growable byte buffer -------------------------------------------- */

typedef struct buf {
  const hetinv_context_t *ctx;
  unsigned char *data;
  size_t len, cap;
  bool failed;
} buf_t;

static void put(buf_t *b, const void *p, size_t n) {
  if (b->failed) return;
  if (b->len + n > b->cap) {
    size_t cap = b->cap ? b->cap : 4096;
    while (cap < b->len + n) cap *= 2;
    unsigned char *grown = hv_alloc(b->ctx, cap);
    if (grown == NULL) {
      b->failed = true;
      return;
    }
    if (b->len) memcpy(grown, b->data, b->len);
    hv_free(b->ctx, b->data);
    b->data = grown;
    b->cap = cap;
  }
  memcpy(b->data + b->len, p, n);
  b->len += n;
}
static void put_u64(buf_t *b, uint64_t v) { put(b, &v, sizeof v); }
static void put_f64(buf_t *b, double v) { put(b, &v, sizeof v); }
static void put_f64s(buf_t *b, const double *v, size_t n) { put(b, v, n * sizeof *v); }

/* --- fingerprint --------------------------------------------------------- */


void hv_ckpt_fingerprint(const hetinv_optimizer_t *opt, hv_ckpt_fingerprint_t *f) {
  memset(f, 0, sizeof *f);
  const hetinv_measurements_t *set = opt->set;
  f->value_count = set->value_count;
  f->rows = (uint64_t)set->row_count;
  f->emitters = (uint64_t)opt->groups.count;
  f->stages = (uint64_t)opt->stage_count;
  for (int32_t s = 0; s < opt->stage_count && s < 64; ++s) {
    const hv_stage_t *st = &opt->stages[s];
    f->stage_k[s] = st->k;
    f->stage_iterations[s] = (uint64_t)st->iterations;
    uint64_t h = HV_FNV_OFFSET;
    if (st->frozen) h = hv_fnv1a(h, st->frozen, st->k);
    h = hv_fnv1a(h, "|", 1);
    if (st->value_mask) h = hv_fnv1a(h, st->value_mask, set->value_count);
    /* A stage's epsilon_start, average_window and settling join its masks' hash: same file layout, and a resume
     * with another ε is refused like one with other masks. 0 (the tunable)
     * adds nothing, so older checkpoints still match. */
    if (st->epsilon_start != 0.0) h = hv_fnv1a(h, &st->epsilon_start, sizeof st->epsilon_start);
    if (st->average_window != 0) h = hv_fnv1a(h, &st->average_window, sizeof st->average_window);
    if (st->settle_epsilon != 0.0) {
      h = hv_fnv1a(h, &st->settle_epsilon, sizeof st->settle_epsilon);
      h = hv_fnv1a(h, &st->settle_fraction, sizeof st->settle_fraction);
    }
    if (st->settle_photons != 0.0) {
      h = hv_fnv1a(h, "p", 1);
      h = hv_fnv1a(h, &st->settle_photons, sizeof st->settle_photons);
      if (st->settle_epsilon == 0.0) h = hv_fnv1a(h, &st->settle_fraction, sizeof st->settle_fraction);
    }
    f->stage_masks[s] = h;
  }
  memcpy(f->param, opt->param, sizeof f->param);
  memcpy(f->lo, opt->lo, sizeof f->lo);
  memcpy(f->hi, opt->hi, sizeof f->hi);
  memcpy(f->est_param, opt->est_param, sizeof f->est_param);
  f->set_hash = hv_set_values_hash(set);
  uint64_t h = HV_FNV_OFFSET;
  size_t v = hetinv_medium_voxel_count(opt->initial);
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) h = hv_fnv1a(h, hetinv_medium_grid(opt->initial, p), v * sizeof(double));
  f->medium_hash = h;
  f->seed = hetinv_context_seed(opt->ctx);
  f->geometry_hash = hv_set_geometry_hash(set);
  f->gain_mode = (uint64_t)opt->gain_mode;
}

const char *hv_ckpt_fingerprint_diff(const hv_ckpt_fingerprint_t *a, const hv_ckpt_fingerprint_t *b, char *msg, size_t len) {
  if (a->value_count != b->value_count || a->rows != b->rows || a->emitters != b->emitters) {
    snprintf(msg, len, "the measurement set differs (%llu values, %llu rows in the checkpoint; %llu, %llu here)",
             (unsigned long long)a->value_count, (unsigned long long)a->rows,
             (unsigned long long)b->value_count, (unsigned long long)b->rows);
    return msg;
  }
  if (a->set_hash != b->set_hash) return "the measured values, weights, clip scales or mask differ";
  if (a->geometry_hash != b->geometry_hash) {
    return "the measurement geometry differs (the box, its indices, or a row's emitter, sensor, pathlength bins or "
           "instrument response)";
  }
  if (a->medium_hash != b->medium_hash) return "the initial medium differs";
  if (a->seed != b->seed) return "the context's seed differs";
  if (a->stages != b->stages) {
    snprintf(msg, len, "the schedule has %llu stages in the checkpoint and %llu here",
             (unsigned long long)a->stages, (unsigned long long)b->stages);
    return msg;
  }
  for (uint64_t s = 0; s < a->stages && s < 64; ++s) {
    if (a->stage_k[s] != b->stage_k[s] || a->stage_iterations[s] != b->stage_iterations[s] ||
        a->stage_masks[s] != b->stage_masks[s]) {
      snprintf(msg, len, "stage %llu differs (entries %llu vs %llu, iterations %llu vs %llu, or its masks, epsilon_start, average_window or settling)",
               (unsigned long long)s, (unsigned long long)a->stage_k[s], (unsigned long long)b->stage_k[s],
               (unsigned long long)a->stage_iterations[s], (unsigned long long)b->stage_iterations[s]);
      return msg;
    }
  }
  for (int p = 0; p < HETINV_OPTIMIZER_PARAM_COUNT_; ++p) {
    if (memcmp(&a->param[p], &b->param[p], sizeof(double)) != 0) {
      snprintf(msg, len, "%s is %.17g in the checkpoint and %.17g here", hv_optimizer_param_name(p),
               a->param[p], b->param[p]);
      return msg;
    }
  }
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) {
    if (memcmp(&a->lo[p], &b->lo[p], sizeof(double)) || memcmp(&a->hi[p], &b->hi[p], sizeof(double))) {
      snprintf(msg, len, "the bounds of %s are [%g, %g] in the checkpoint and [%g, %g] here",
               hetinv_param_name(p), a->lo[p], a->hi[p], b->lo[p], b->hi[p]);
      return msg;
    }
  }
  return NULL;
}

static void put_fingerprint(buf_t *b, const hv_ckpt_fingerprint_t *f) { put(b, f, sizeof *f); }

/* --- write --------------------------------------------------------------- */

hetinv_result_t hv_checkpoint_write(const hetinv_optimizer_t *opt, const char *path) {
  const hetinv_context_t *ctx = opt->ctx;
  if (hetinv_context_rank(ctx) != 0) return HETINV_SUCCESS; /* one writer under MPI: every rank holds the same state */
  buf_t b = {.ctx = ctx};
  put(&b, HV_CKPT_MAGIC, 8);
  put_u64(&b, HV_CKPT_BYTE_ORDER_TAG);
  put_u64(&b, HV_CKPT_FORMAT_VERSION);
  hv_ckpt_fingerprint_t f;
  hv_ckpt_fingerprint(opt, &f);
  put_fingerprint(&b, &f);
  put_u64(&b, (uint64_t)opt->stage);
  put_u64(&b, (uint64_t)opt->stage_iteration);
  put_u64(&b, (uint64_t)opt->iteration);
  put_f64(&b, opt->elapsed);
  put_u64(&b, opt->k);
  put_f64s(&b, opt->pi, opt->k);
  put_f64s(&b, opt->acc1, opt->k);
  put_f64s(&b, opt->acc2, opt->k);
  put_u64(&b, (uint64_t)opt->window);
  put_u64(&b, (uint64_t)opt->ring_count);
  put_u64(&b, (uint64_t)opt->ring_head);
  put_f64s(&b, opt->ring, (size_t)opt->window * opt->k);
  put_u64(&b, opt->loss_count);
  put_f64s(&b, opt->losses, opt->loss_count);
  size_t v = hetinv_medium_voxel_count(opt->base);
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) put_f64s(&b, hetinv_medium_grid(opt->base, p), v);
  put_u64(&b, hv_fnv1a(HV_FNV_OFFSET, b.data, b.len));
  if (b.failed) {
    hv_free(ctx, b.data);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot build the checkpoint of '%s'", path);
  }
  hv_atomic_file_t af;
  hetinv_result_t r = hv_atomic_open(ctx, path, 1, &af);
  if (r == HETINV_SUCCESS) {
    if (fwrite(b.data, 1, b.len, af.fp) != b.len) {
      int err = errno;
      hv_atomic_abort(&af);
      r = HV_FAIL(ctx, HETINV_ERROR_IO, "cannot write the checkpoint '%s': %s", path,
                  strerror(err != 0 ? err : EIO));
    } else {
      r = hv_atomic_commit(&af);
    }
  }
  hv_free(ctx, b.data);
  return r;
}

HETINV_API hetinv_result_t hetinv_optimizer_save(const hetinv_optimizer_t *optimizer, const char *path) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  HV_CHECK_NULL(optimizer->ctx, path);
  if (!optimizer->started) {
    return HV_FAIL(optimizer->ctx, HETINV_ERROR_INVALID_STATE, "nothing to save: the run has not started");
  }
  return hv_checkpoint_write(optimizer, path);
}

