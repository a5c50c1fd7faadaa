/* Checkpoints: the optimizer's whole run state in one binary file, written
 * atomically, with a fingerprint of the configuration that produced it
 * (so a resume into a different problem is refused, naming the
 * difference) and a checksum (so a damaged file is refused).
 *
 * Layout, little-endian host order, every field 8 bytes:
 *   "HVCKPT01", byte-order tag, format version,
 *   fingerprint: value count, rows, emitters, stages and per stage
 *     (entries, iterations, hash of its masks), the tunables, the bounds,
 *     the estimator's tunables, hash of the set, hash of the initial
 *     medium, context seed;
 *   state: stage, stage iteration, iteration, elapsed, entries, π and two
 *     accumulators, window, ring count and head, ring, loss count and
 *     losses, the base medium's three grids;
 *   FNV-1a 64 of everything before. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "core/error.h"
#include "io/atomic_file.h"
#include "optimize/optimizer_internal.h"
#include "sampling/measurements_internal.h"

#define MAGIC "HVCKPT01"
#define BYTE_ORDER_TAG UINT64_C(0x0102030405060708)
#define FORMAT_VERSION 1u

static uint64_t fnv1a(uint64_t h, const void *data, size_t n) {
  const unsigned char *p = data;
  for (size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= UINT64_C(0x100000001b3);
  }
  return h;
}
#define FNV_OFFSET UINT64_C(0xcbf29ce484222325)

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

typedef struct fingerprint {
  uint64_t value_count, rows, emitters, stages;
  uint64_t stage_k[64], stage_iterations[64], stage_masks[64]; /* first 64 stages */
  double param[HETINV_OPTIMIZER_PARAM_COUNT_];
  double lo[HETINV_PARAM_COUNT], hi[HETINV_PARAM_COUNT];
  double est_param[HETINV_ESTIMATOR_PARAM_COUNT_];
  uint64_t set_hash, medium_hash, seed;
} fingerprint_t;

static void fingerprint(const hetinv_optimizer_t *opt, fingerprint_t *f) {
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
    uint64_t h = FNV_OFFSET;
    if (st->frozen) h = fnv1a(h, st->frozen, st->k);
    h = fnv1a(h, "|", 1);
    if (st->value_mask) h = fnv1a(h, st->value_mask, set->value_count);
    f->stage_masks[s] = h;
  }
  memcpy(f->param, opt->param, sizeof f->param);
  memcpy(f->lo, opt->lo, sizeof f->lo);
  memcpy(f->hi, opt->hi, sizeof f->hi);
  memcpy(f->est_param, opt->est_param, sizeof f->est_param);
  uint64_t h = FNV_OFFSET;
  size_t n = set->value_count;
  h = fnv1a(h, set->values, n * sizeof(double));
  h = fnv1a(h, set->weights, n * sizeof(double));
  h = fnv1a(h, set->mask, n);
  f->set_hash = h;
  h = FNV_OFFSET;
  size_t v = hetinv_medium_voxel_count(opt->initial);
  for (int p = 0; p < HETINV_PARAM_COUNT; ++p) h = fnv1a(h, hetinv_medium_grid(opt->initial, p), v * sizeof(double));
  f->medium_hash = h;
  f->seed = hetinv_context_seed(opt->ctx);
}

/* Names the first difference between two fingerprints, or NULL. */
static const char *fingerprint_diff(const fingerprint_t *a, const fingerprint_t *b, char *msg, size_t len) {
  if (a->value_count != b->value_count || a->rows != b->rows || a->emitters != b->emitters) {
    snprintf(msg, len, "the measurement set differs (%llu values, %llu rows in the checkpoint; %llu, %llu here)",
             (unsigned long long)a->value_count, (unsigned long long)a->rows,
             (unsigned long long)b->value_count, (unsigned long long)b->rows);
    return msg;
  }
  if (a->set_hash != b->set_hash) return "the measured values, weights or mask differ";
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
      snprintf(msg, len, "stage %llu differs (entries %llu vs %llu, iterations %llu vs %llu, or its masks)",
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

static void put_fingerprint(buf_t *b, const fingerprint_t *f) { put(b, f, sizeof *f); }

/* --- write --------------------------------------------------------------- */

hetinv_result_t hv_checkpoint_write(const hetinv_optimizer_t *opt, const char *path) {
  const hetinv_context_t *ctx = opt->ctx;
  if (hetinv_context_rank(ctx) != 0) return HETINV_SUCCESS; /* one writer under MPI: every rank holds the same state */
  buf_t b = {.ctx = ctx};
  put(&b, MAGIC, 8);
  put_u64(&b, BYTE_ORDER_TAG);
  put_u64(&b, FORMAT_VERSION);
  fingerprint_t f;
  fingerprint(opt, &f);
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
  put_u64(&b, fnv1a(FNV_OFFSET, b.data, b.len));
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

/* --- read ---------------------------------------------------------------- */

typedef struct reader {
  const unsigned char *p;
  size_t len, at;
  bool short_read;
} reader_t;

static void get(reader_t *r, void *out, size_t n) {
  if (r->short_read || n > r->len - r->at) {
    r->short_read = true;
    memset(out, 0, n);
    return;
  }
  memcpy(out, r->p + r->at, n);
  r->at += n;
}
static uint64_t get_u64(reader_t *r) {
  uint64_t v;
  get(r, &v, sizeof v);
  return v;
}

static uint64_t stored_checksum(const unsigned char *data, size_t len) {
  uint64_t sum;
  memcpy(&sum, data + len - 8, sizeof sum);
  return sum;
}

static hetinv_result_t read_file(const hetinv_context_t *ctx, const char *path, unsigned char **data,
                                 size_t *len) {
  FILE *fp = fopen(path, "rb");
  if (fp == NULL) return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot open the checkpoint '%s'", path);
  long size = -1;
  if (fseek(fp, 0, SEEK_END) == 0) size = ftell(fp);
  if (size < 0 || fseek(fp, 0, SEEK_SET) != 0) {
    fclose(fp);
    return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot size the checkpoint '%s'", path);
  }
  *data = size > 0 ? hv_alloc(ctx, (size_t)size) : NULL;
  if (size > 0 && *data == NULL) {
    fclose(fp);
    return HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot hold the %ld-byte checkpoint '%s'", size, path);
  }
  size_t got = size > 0 ? fread(*data, 1, (size_t)size, fp) : 0;
  fclose(fp);
  if (got != (size_t)size) {
    hv_free(ctx, *data);
    return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot read the checkpoint '%s'", path);
  }
  *len = (size_t)size;
  return HETINV_SUCCESS;
}

HETINV_API hetinv_result_t hetinv_optimizer_resume(hetinv_optimizer_t *optimizer, const char *path) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, optimizer);
  hetinv_optimizer_t *opt = optimizer;
  const hetinv_context_t *ctx = opt->ctx;
  HV_CHECK_NULL(ctx, path);
  if (opt->started) return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE, "the run has started; resume into a fresh optimizer");
  if (opt->stage_count == 0) return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE, "add the run's stages before resuming it");
  unsigned char *data = NULL;
  size_t len = 0;
  hetinv_result_t r = read_file(ctx, path, &data, &len);
  if (r != HETINV_SUCCESS) return r;

  reader_t rd = {.p = data, .len = len};
  char magic[8];
  get(&rd, magic, 8);
  uint64_t tag = get_u64(&rd), version = get_u64(&rd);
  /* The checksum before the version: a damaged header is damage, not a
   * newer format; an intact file of another format is unsupported. */
  if (rd.short_read || memcmp(magic, MAGIC, 8) != 0) {
    r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s' is not a libhetinv checkpoint (bad magic)", path);
  } else if (len < rd.at + 8 || fnv1a(FNV_OFFSET, data, len - 8) != stored_checksum(data, len)) {
    r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s' is damaged: its checksum does not match", path);
  } else if (tag != BYTE_ORDER_TAG || version != FORMAT_VERSION) {
    r = HV_FAIL(ctx, HETINV_ERROR_UNSUPPORTED, "'%s': checkpoint format %llu or byte order not supported", path,
                (unsigned long long)version);
  }
  fingerprint_t saved, here;
  char msg[256];
  const char *diff = NULL;
  if (r == HETINV_SUCCESS) {
    get(&rd, &saved, sizeof saved);
    hv_optimizer_resolve_iterations(opt);
    fingerprint(opt, &here);
    memcpy(here.est_param, saved.est_param, sizeof here.est_param); /* checked at the next run */
    diff = fingerprint_diff(&saved, &here, msg, sizeof msg);
    if (diff) r = HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "'%s' was written for another run: %s", path, diff);
  }
  hetinv_medium_t *base = NULL;
  if (r == HETINV_SUCCESS) {
    uint64_t stage = get_u64(&rd), stage_it = get_u64(&rd), it = get_u64(&rd);
    double elapsed;
    get(&rd, &elapsed, sizeof elapsed);
    uint64_t k = get_u64(&rd);
    if (rd.short_read || stage >= (uint64_t)opt->stage_count || k != opt->stages[stage].k) {
      r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s': inconsistent stage state", path);
    } else {
      opt->stage = (int32_t)stage;
      r = hv_optimizer_alloc_stage_arrays(opt, (size_t)k);
      opt->stage_iteration = (int64_t)stage_it;
      opt->iteration = (int64_t)it;
      opt->elapsed = elapsed;
    }
    if (r == HETINV_SUCCESS) {
      get(&rd, opt->pi, opt->k * sizeof(double));
      get(&rd, opt->acc1, opt->k * sizeof(double));
      get(&rd, opt->acc2, opt->k * sizeof(double));
      uint64_t window = get_u64(&rd), count = get_u64(&rd), head = get_u64(&rd);
      if (window != (uint64_t)opt->window || count > window || head >= window) {
        r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s': inconsistent averaging window", path);
      } else {
        opt->ring_count = (int32_t)count;
        opt->ring_head = (int32_t)head;
        get(&rd, opt->ring, (size_t)window * opt->k * sizeof(double));
      }
    }
    uint64_t losses = r == HETINV_SUCCESS ? get_u64(&rd) : 0;
    /* Bounded by the bytes left before anything is allocated: a consistent
     * but hostile count must not ask for terabytes. */
    if (r == HETINV_SUCCESS && (rd.short_read || losses != (uint64_t)opt->iteration ||
                                losses > (len - 8 - rd.at) / sizeof(double))) {
      r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s': inconsistent loss history", path);
    }
    if (r == HETINV_SUCCESS && losses > 0) {
      hv_free(ctx, opt->losses);
      opt->loss_capacity = opt->loss_count = 0;
      opt->losses = hv_calloc(ctx, (size_t)losses, sizeof(double));
      if (opt->losses == NULL) {
        r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot hold %llu losses", (unsigned long long)losses);
      } else {
        opt->loss_capacity = opt->loss_count = (size_t)losses;
        get(&rd, opt->losses, (size_t)losses * sizeof(double));
      }
    }
    if (r == HETINV_SUCCESS) r = hetinv_medium_clone(opt->initial, &base);
    size_t v = hetinv_medium_voxel_count(opt->initial);
    double *grid = r == HETINV_SUCCESS ? hv_calloc(ctx, v, sizeof(double)) : NULL;
    if (r == HETINV_SUCCESS && grid == NULL) r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot hold the base medium");
    for (int p = 0; r == HETINV_SUCCESS && p < HETINV_PARAM_COUNT; ++p) {
      get(&rd, grid, v * sizeof(double));
      r = rd.short_read ? HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s' is truncated", path)
                        : hetinv_medium_set_grid(base, p, grid, v);
      /* Values outside the parameter's domain are damage, not a bad argument. */
      if (r == HETINV_ERROR_INVALID_ARGUMENT) {
        r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s': the base medium holds an invalid %s", path,
                    hetinv_param_name(p));
      }
    }
    hv_free(ctx, grid);
    if (r == HETINV_SUCCESS && rd.at + 8 != len) {
      r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE, "'%s': %zu unexpected bytes", path, len - 8 - rd.at);
    }
  }
  hv_free(ctx, data);
  if (r != HETINV_SUCCESS) {
    /* Leave the optimizer as it was: not started, no stage state. */
    hetinv_medium_destroy(&base);
    hv_optimizer_free_stage_arrays(opt);
    hv_free(ctx, opt->losses);
    opt->losses = NULL;
    opt->loss_count = opt->loss_capacity = 0;
    opt->stage = 0;
    opt->stage_iteration = opt->iteration = 0;
    opt->elapsed = 0.0;
    return r;
  }
  opt->base = base;
  memcpy(opt->est_param, saved.est_param, sizeof opt->est_param);
  opt->verify_est_param = true;
  opt->started = true;
  return HETINV_SUCCESS;
}
