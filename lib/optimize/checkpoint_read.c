/* Reading a checkpoint. A checkpoint is input: its checksum shows that it
 * is undamaged, not that this library wrote it for this run (a stale or
 * crafted file carries a valid checksum too). So the file must be a
 * regular file no larger than the configured run can write, and every
 * field is checked against the optimizer's configuration before it is
 * used or anything is sized from it: the position (stage, iterations)
 * within the schedule, the file's exact length for that position, π and
 * the averaging ring inside the box, the method's accumulators in their
 * domain, the loss history, the estimator's tunables, the base medium.
 * A failure is HETINV_ERROR_CORRUPT_FILE naming the field, its value and
 * the limit, and leaves the optimizer as it was. */
#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/alloc.h"
#include "core/error.h"
#include "estimator/estimator_internal.h"
#include "medium/medium_internal.h"
#include "optimize/checkpoint_internal.h"

typedef struct reader {
  const hetinv_context_t *ctx;
  const char *name;
  const unsigned char *p;
  size_t len, at;
  bool short_read;
  size_t older_format_less; /* bytes an older format's fingerprint lacks */
  bool has_geometry;        /* format 7 on: the set's geometry hash and the gain mode */
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
static double get_f64(reader_t *r) {
  double v;
  get(r, &v, sizeof v);
  return v;
}

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
/* HETINV_ERROR_CORRUPT_FILE, the message prefixed with the file's name. */
static hetinv_result_t corrupt(const reader_t *r, const char *fmt, ...) {
  char msg[768];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  return HV_FAIL(r->ctx, HETINV_ERROR_CORRUPT_FILE, "%s: %s", r->name, msg);
}

/* --- sizes ----------------------------------------------------------------- */

static uint64_t add_sat(uint64_t a, uint64_t b) { return a > UINT64_MAX - b ? UINT64_MAX : a + b; }
static uint64_t mul_sat(uint64_t a, uint64_t b) { return b != 0 && a > UINT64_MAX / b ? UINT64_MAX : a * b; }

/* The length of a checkpoint of this run at a stage of k entries after
 * `iterations` iterations in all (saturating). */
static uint64_t checkpoint_size(const hetinv_optimizer_t *opt, uint64_t k, uint64_t iterations) {
  uint64_t window = (uint64_t)opt->param[HETINV_OPTIMIZER_AVERAGE_WINDOW];
  uint64_t voxels = hetinv_medium_voxel_count(opt->initial);
  uint64_t n = 8 + 8 + 8 + sizeof(hv_ckpt_fingerprint_t); /* magic, tag, version, fingerprint */
  n = add_sat(n, 5 * 8);                                  /* stage, iterations, elapsed, entries */
  n = add_sat(n, mul_sat(8, mul_sat(k, 3)));              /* π, accumulators */
  n = add_sat(n, 3 * 8);                                  /* window, ring count and head */
  n = add_sat(n, mul_sat(8, mul_sat(k, window)));         /* ring */
  n = add_sat(n, add_sat(8, mul_sat(8, iterations)));     /* losses */
  n = add_sat(n, mul_sat(8, mul_sat(voxels, HETINV_PARAM_COUNT)));
  return add_sat(n, 8); /* checksum */
}

/* The largest checkpoint this run can write: its largest stage after all
 * its iterations. A file beyond it is refused before anything is read. */
static uint64_t max_checkpoint_size(const hetinv_optimizer_t *opt) {
  uint64_t k = 0, iterations = 0;
  for (int32_t s = 0; s < opt->stage_count; ++s) {
    if (opt->stages[s].k > k) k = opt->stages[s].k;
    iterations = add_sat(iterations, (uint64_t)opt->stages[s].iterations);
  }
  return checkpoint_size(opt, k, iterations);
}

/* --- the file -------------------------------------------------------------- */

static const char *another_run(const hetinv_optimizer_t *opt, int fd, char *msg, size_t size);

/* Reads a regular file of at most `limit` bytes. O_NONBLOCK keeps the open
 * of a FIFO from waiting for a writer (it is refused after fstat); it does
 * not change reads of a regular file. */
static hetinv_result_t read_file(const hetinv_optimizer_t *opt, const char *path, uint64_t limit,
                                 unsigned char **data, size_t *len) {
  const hetinv_context_t *ctx = opt->ctx;
  *data = NULL;
  *len = 0;
  int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return HV_FAIL(ctx, HETINV_ERROR_IO, "cannot open the checkpoint '%s': %s", path, strerror(errno));
  struct stat st;
  hetinv_result_t r = HETINV_SUCCESS;
  if (fstat(fd, &st) != 0) {
    r = HV_FAIL(ctx, HETINV_ERROR_IO, "cannot stat the checkpoint '%s': %s", path, strerror(errno));
  } else if (!S_ISREG(st.st_mode)) {
    r = HV_FAIL(ctx, HETINV_ERROR_IO, "the checkpoint '%s' is not a regular file", path);
  } else if (st.st_size < 0 || (uint64_t)st.st_size > limit || (uint64_t)st.st_size > SIZE_MAX) {
    char msg[256];
    const char *diff = another_run(opt, fd, msg, sizeof msg);
    if (diff != NULL) {
      r = HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "'%s' was written for another run: %s", path, diff);
    } else {
      r = HV_FAIL(ctx, HETINV_ERROR_CORRUPT_FILE,
                  "the checkpoint '%s' is %lld bytes; a checkpoint of this run has at most %llu", path,
                  (long long)st.st_size, (unsigned long long)limit);
    }
  }
  size_t size = r == HETINV_SUCCESS ? (size_t)st.st_size : 0;
  unsigned char *buf = size > 0 ? hv_alloc(ctx, size) : NULL;
  if (r == HETINV_SUCCESS && size > 0 && buf == NULL) {
    r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot hold the %zu-byte checkpoint '%s'", size, path);
  }
  size_t got = 0;
  while (r == HETINV_SUCCESS && got < size) {
    ssize_t n = read(fd, buf + got, size - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      r = HV_FAIL(ctx, HETINV_ERROR_IO, "cannot read the checkpoint '%s': %s", path,
                  n < 0 ? strerror(errno) : "it became shorter while being read");
    } else {
      got += (size_t)n;
    }
  }
  close(fd);
  if (r != HETINV_SUCCESS) {
    hv_free(ctx, buf);
    return r;
  }
  *data = buf;
  *len = size;
  return HETINV_SUCCESS;
}

/* --- the fields ------------------------------------------------------------ */

/* The estimator's tunables the run used: each inside its bounds (EPOCH is
 * not recorded: 0). They are compared with the estimator when the run
 * continues. */
static hetinv_result_t check_est_params(const reader_t *rd, const double *est) {
  for (int p = 0; p < HETINV_ESTIMATOR_PARAM_COUNT_; ++p) {
    double lo = 0.0, hi = 0.0;
    if (p == HETINV_ESTIMATOR_EPOCH) {
      lo = hi = 0.0;
    } else {
      hetinv_estimator_param_bounds(p, &lo, &hi);
    }
    if (!(est[p] >= lo && est[p] <= hi)) {
      return corrupt(rd, "the estimator's %s is %.17g; it must be in [%.17g, %.17g]", hv_estimator_param_name(p),
                     est[p], lo, hi);
    }
  }
  return HETINV_SUCCESS;
}

typedef struct position {
  uint64_t stage, stage_iteration, iteration, k;
  double elapsed;
} position_t;

/* Where the run stands: a stage of the schedule, no more of its iterations
 * than it has, and in all the iterations of the stages before it (each ran
 * its count, or at least 2 PLATEAU_WINDOW before ending on a plateau) plus
 * those of this stage. */
static hetinv_result_t check_position(const reader_t *rd, const hetinv_optimizer_t *opt, const position_t *at) {
  if (at->stage >= (uint64_t)opt->stage_count) {
    return corrupt(rd, "the stage is %llu; the schedule has %d stages", (unsigned long long)at->stage,
                   (int)opt->stage_count);
  }
  const hv_stage_t *st = &opt->stages[at->stage];
  if (at->k != st->k) {
    return corrupt(rd, "stage %llu has %llu entries; its map has %zu", (unsigned long long)at->stage,
                   (unsigned long long)at->k, st->k);
  }
  if (at->stage_iteration > (uint64_t)st->iterations) {
    return corrupt(rd, "the stage iteration is %llu; stage %llu has %lld iterations",
                   (unsigned long long)at->stage_iteration, (unsigned long long)at->stage,
                   (long long)st->iterations);
  }
  uint64_t w = (uint64_t)opt->param[HETINV_OPTIMIZER_PLATEAU_WINDOW];
  uint64_t lo = at->stage_iteration, hi = at->stage_iteration;
  for (uint64_t s = 0; s < at->stage; ++s) {
    uint64_t n = (uint64_t)opt->stages[s].iterations;
    lo = add_sat(lo, w > 0 && 2 * w < n ? 2 * w : n);
    hi = add_sat(hi, n);
  }
  if (at->iteration < lo || at->iteration > hi) {
    return corrupt(rd, "the iteration is %llu; at iteration %llu of stage %llu it must be in [%llu, %llu]",
                   (unsigned long long)at->iteration, (unsigned long long)at->stage_iteration,
                   (unsigned long long)at->stage, (unsigned long long)lo, (unsigned long long)hi);
  }
  if (!(isfinite(at->elapsed) && at->elapsed >= 0.0)) {
    return corrupt(rd, "the elapsed time is %g s; it must be finite and >= 0", at->elapsed);
  }
  return HETINV_SUCCESS;
}

/* Entries finite and inside the range the stage's iterates move in (its
 * box, widened by HETINV_OPTIMIZER_BOX_MARGIN; NaN is not; an unbounded
 * side does not admit an infinity). */
static hetinv_result_t check_in_box(const reader_t *rd, const hetinv_optimizer_t *opt, const double *v,
                                    const char *what, int32_t slot) {
  for (size_t i = 0; i < opt->k; ++i) {
    if (!(isfinite(v[i]) && v[i] >= opt->move_lo_k[i] && v[i] <= opt->move_hi_k[i])) {
      char where[64] = "";
      if (slot >= 0) snprintf(where, sizeof where, " (iterate %d of the averaging ring)", (int)slot);
      return corrupt(rd, "%s[%zu]%s is %.17g; its bounds are [%.17g, %.17g]", what, i, where, v[i],
                     opt->move_lo_k[i], opt->move_hi_k[i]);
    }
  }
  return HETINV_SUCCESS;
}

/* The method's accumulators: running means of g² (ADADELTA's E[g²] and
 * E[Δx²], AdaGrad's sum, Adam's second moment) are finite and >= 0; Adam's
 * first moment is finite; the ones the method does not use are finite. */
static hetinv_result_t check_accumulators(const reader_t *rd, const hetinv_optimizer_t *opt) {
  int method = (int)opt->param[HETINV_OPTIMIZER_METHOD];
  bool squares[2] = {method == HETINV_METHOD_ADADELTA || method == HETINV_METHOD_ADAGRAD,
                     method == HETINV_METHOD_ADADELTA || method == HETINV_METHOD_ADAM};
  const double *acc[2] = {opt->acc1, opt->acc2};
  for (int a = 0; a < 2; ++a) {
    for (size_t i = 0; i < opt->k; ++i) {
      double v = acc[a][i];
      if (!isfinite(v) || (squares[a] && v < 0.0)) {
        return corrupt(rd, "accumulator %d of entry %zu is %g; it must be finite%s", a + 1, i, v,
                       squares[a] ? " and >= 0 (a mean of squared gradients)" : "");
      }
    }
  }
  return HETINV_SUCCESS;
}

/* The averaging ring: the configured window; it fills from slot 0 when the
 * stage starts and holds min(stage iteration, window) iterates, the next
 * going to slot (stage iteration mod window). Its iterates are π's, inside
 * the box; unused slots are finite. */
static hetinv_result_t read_ring(reader_t *rd, hetinv_optimizer_t *opt, uint64_t stage_iteration) {
  uint64_t window = get_u64(rd), count = get_u64(rd), head = get_u64(rd);
  uint64_t w = (uint64_t)opt->window;
  uint64_t want_count = stage_iteration < w ? stage_iteration : w, want_head = stage_iteration % w;
  if (window != w) {
    return corrupt(rd, "the averaging window is %llu; HETINV_OPTIMIZER_AVERAGE_WINDOW is %llu",
                   (unsigned long long)window, (unsigned long long)w);
  }
  if (count != want_count || head != want_head) {
    return corrupt(rd,
                   "the averaging ring holds %llu iterates and its head is %llu; after %llu iterations of the "
                   "stage with a window of %llu they are %llu and %llu",
                   (unsigned long long)count, (unsigned long long)head, (unsigned long long)stage_iteration,
                   (unsigned long long)w, (unsigned long long)want_count, (unsigned long long)want_head);
  }
  get(rd, opt->ring, (size_t)w * opt->k * sizeof(double));
  for (uint64_t j = 0; j < w; ++j) {
    const double *it = opt->ring + (size_t)j * opt->k;
    if (j < count) {
      hetinv_result_t r = check_in_box(rd, opt, it, "pi", (int32_t)j);
      if (r != HETINV_SUCCESS) return r;
      continue;
    }
    for (size_t i = 0; i < opt->k; ++i) {
      if (!isfinite(it[i])) {
        return corrupt(rd, "unused slot %llu of the averaging ring holds %g at entry %zu; it must be finite",
                       (unsigned long long)j, it[i], i);
      }
    }
  }
  opt->ring_count = (int32_t)count;
  opt->ring_head = (int32_t)head;
  return HETINV_SUCCESS;
}

/* One loss per iteration done, each >= 0 (a weighted sum of squares). */
static hetinv_result_t read_losses(reader_t *rd, hetinv_optimizer_t *opt, uint64_t iteration) {
  uint64_t count = get_u64(rd);
  if (count != iteration) {
    return corrupt(rd, "the loss history has %llu losses; the run has done %llu iterations",
                   (unsigned long long)count, (unsigned long long)iteration);
  }
  if (count == 0) return HETINV_SUCCESS;
  /* count is bounded by the schedule and matches the file's length. */
  opt->losses = hv_calloc(rd->ctx, (size_t)count, sizeof(double));
  if (opt->losses == NULL) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot hold %llu losses",
                   (unsigned long long)count);
  }
  opt->loss_capacity = opt->loss_count = (size_t)count;
  get(rd, opt->losses, (size_t)count * sizeof(double));
  for (size_t i = 0; i < opt->loss_count; ++i) {
    if (!(opt->losses[i] >= 0.0)) {
      return corrupt(rd, "loss %zu is %g; it must be >= 0", i, opt->losses[i]);
    }
  }
  return HETINV_SUCCESS;
}

/* The base medium: the initial medium with the results of the stages
 * before this one applied. A parameter no earlier stage frees is the
 * initial medium's, bit for bit; one that an earlier stage frees holds
 * interpolations of that stage's averaged π, so it is inside the bounds
 * (up to the rounding of the up to 8 interpolation terms). Every value is
 * in its parameter's domain. */
static hetinv_result_t check_base_grid(const reader_t *rd, const hetinv_optimizer_t *opt, hetinv_param_t p,
                                       const double *grid, size_t v) {
  uint32_t freed = 0;
  for (int32_t s = 0; s < opt->stage; ++s) freed |= hetinv_param_map_free_mask(opt->stages[s].map);
  const double *initial = hetinv_medium_grid(opt->initial, p);
  double lo = opt->lo[p], hi = opt->hi[p];
  double slack = 16.0 * DBL_EPSILON * fmax(isfinite(lo) ? fabs(lo) : 0.0, isfinite(hi) ? fabs(hi) : 0.0);
  for (size_t i = 0; i < v; ++i) {
    const char *rule = hv_medium_value_rule(p, grid[i]);
    if (rule != NULL) {
      return corrupt(rd, "the base medium's %s of voxel %zu is %g; %s", hetinv_param_name(p), i, grid[i], rule);
    }
    if (!(freed & (1u << p)) && memcmp(&grid[i], &initial[i], sizeof(double)) != 0) {
      return corrupt(rd,
                     "the base medium's %s of voxel %zu is %.17g in stage %d; no earlier stage frees %s, and "
                     "the initial medium's is %.17g",
                     hetinv_param_name(p), i, grid[i], (int)opt->stage, hetinv_param_name(p), initial[i]);
    }
    if ((freed & (1u << p)) && !(grid[i] >= lo - slack && grid[i] <= hi + slack)) {
      return corrupt(rd, "the base medium's %s of voxel %zu is %.17g; its bounds are [%.17g, %.17g]",
                     hetinv_param_name(p), i, grid[i], lo, hi);
    }
  }
  return HETINV_SUCCESS;
}

static hetinv_result_t read_base(reader_t *rd, const hetinv_optimizer_t *opt, hetinv_medium_t **out) {
  *out = NULL;
  hetinv_medium_t *base = NULL;
  hetinv_result_t r = hetinv_medium_clone(opt->initial, &base);
  if (r != HETINV_SUCCESS) return r;
  size_t v = hetinv_medium_voxel_count(opt->initial);
  double *grid = hv_calloc(rd->ctx, v, sizeof(double));
  if (grid == NULL) r = HV_FAIL(rd->ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot hold the base medium");
  for (int p = 0; r == HETINV_SUCCESS && p < HETINV_PARAM_COUNT; ++p) {
    get(rd, grid, v * sizeof(double));
    r = check_base_grid(rd, opt, p, grid, v);
    if (r == HETINV_SUCCESS) r = hetinv_medium_set_grid(base, p, grid, v);
  }
  hv_free(rd->ctx, grid);
  if (r != HETINV_SUCCESS) {
    hetinv_medium_destroy(&base);
    return r;
  }
  *out = base;
  return HETINV_SUCCESS;
}

static uint64_t stored_checksum(const reader_t *rd) {
  uint64_t sum;
  memcpy(&sum, rd->p + rd->len - 8, sizeof sum);
  return sum;
}

/* The fingerprint of a checkpoint of format `version`. An older format's
 * tunable lists end before the tunables added since (each the last of its
 * list when added), which read as 0, their value in every such run. */
static void read_fingerprint(reader_t *rd, uint64_t version, hv_ckpt_fingerprint_t *saved) {
  _Static_assert(HETINV_OPTIMIZER_BOX_MARGIN + 1 == HETINV_OPTIMIZER_PARAM_COUNT_, "BOX_MARGIN is the last tunable");
  _Static_assert(HETINV_OPTIMIZER_MULTISCALE + 1 == HETINV_OPTIMIZER_BOX_MARGIN, "MULTISCALE came just before");
  _Static_assert(HETINV_OPTIMIZER_SMOOTHNESS + 1 == HETINV_OPTIMIZER_MULTISCALE, "SMOOTHNESS came just before");
  _Static_assert(HETINV_ESTIMATOR_LOSS_CLIP + 1 == HETINV_ESTIMATOR_PARAM_COUNT_, "LOSS_CLIP is the last tunable");
  _Static_assert(offsetof(hv_ckpt_fingerprint_t, lo) ==
                     offsetof(hv_ckpt_fingerprint_t, param) + sizeof saved->param, "no padding");
  _Static_assert(offsetof(hv_ckpt_fingerprint_t, set_hash) ==
                     offsetof(hv_ckpt_fingerprint_t, est_param) + sizeof saved->est_param, "no padding");
  size_t params = version >= 6   ? HETINV_OPTIMIZER_PARAM_COUNT_
                  : version >= 5 ? HETINV_OPTIMIZER_BOX_MARGIN
                  : version >= 4 ? HETINV_OPTIMIZER_MULTISCALE
                                 : HETINV_OPTIMIZER_SMOOTHNESS;
  size_t est_params = version >= 3 ? HETINV_ESTIMATOR_PARAM_COUNT_ : HETINV_ESTIMATOR_LOSS_CLIP;
  memset(saved, 0, sizeof *saved);
  unsigned char *base = (unsigned char *)saved;
  size_t at_param = offsetof(hv_ckpt_fingerprint_t, param), at_lo = offsetof(hv_ckpt_fingerprint_t, lo);
  size_t at_est = offsetof(hv_ckpt_fingerprint_t, est_param), at_tail = offsetof(hv_ckpt_fingerprint_t, set_hash);
  get(rd, base, at_param);
  get(rd, base + at_param, params * sizeof(double));
  get(rd, base + at_lo, at_est - at_lo);
  get(rd, base + at_est, est_params * sizeof(double));
  size_t at_geometry = offsetof(hv_ckpt_fingerprint_t, geometry_hash);
  size_t tail = version >= 7 ? sizeof *saved - at_tail : at_geometry - at_tail;
  get(rd, base + at_tail, tail);
  rd->older_format_less = (HETINV_OPTIMIZER_PARAM_COUNT_ - params + HETINV_ESTIMATOR_PARAM_COUNT_ - est_params) * sizeof(double) +
                          (sizeof *saved - at_tail - tail);
  rd->has_geometry = version >= 7;
}

/* What differs between the configuration a fingerprint was read for
 * (read_fingerprint) and this run's, or NULL. */
static const char *fingerprint_diff(const reader_t *rd, const hetinv_optimizer_t *opt,
                                    const hv_ckpt_fingerprint_t *saved, char *msg, size_t size) {
  hv_ckpt_fingerprint_t here;
  hv_ckpt_fingerprint(opt, &here);
  memcpy(here.est_param, saved->est_param, sizeof here.est_param); /* compared when the run continues */
  here.gain_mode = saved->gain_mode;                                 /* so is this */
  if (!rd->has_geometry) here.geometry_hash = saved->geometry_hash; /* an older format: cannot be checked */
  return hv_ckpt_fingerprint_diff(saved, &here, msg, size);
}

/* A file longer than any checkpoint of this run is refused from its size,
 * unread. Most often it is an intact checkpoint of another configuration
 * (more iterations, a larger map: a rerun under changed settings), whose
 * difference is the reason to give, as for a file of the right size; so
 * its fixed-size head is read and compared. The checksum over the whole
 * file is not verified here, but the file is refused either way: an
 * unverified head only chooses the message. NULL where the head is not a
 * checkpoint's of a supported format or names no difference. */
static const char *another_run(const hetinv_optimizer_t *opt, int fd, char *msg, size_t size) {
  unsigned char head[3 * 8 + sizeof(hv_ckpt_fingerprint_t)];
  ssize_t n = pread(fd, head, sizeof head, 0);
  if (n <= 0) return NULL;
  reader_t rd = {.ctx = opt->ctx, .name = "", .p = head, .len = (size_t)n};
  char magic[8];
  get(&rd, magic, 8);
  uint64_t tag = get_u64(&rd), version = get_u64(&rd);
  if (rd.short_read || memcmp(magic, HV_CKPT_MAGIC, 8) != 0 || tag != HV_CKPT_BYTE_ORDER_TAG ||
      version < HV_CKPT_FORMAT_OLDEST || version > HV_CKPT_FORMAT_VERSION) {
    return NULL;
  }
  hv_ckpt_fingerprint_t saved;
  read_fingerprint(&rd, version, &saved);
  return rd.short_read ? NULL : fingerprint_diff(&rd, opt, &saved, msg, size);
}

/* Header, checksum and format; then the configuration it was written for. */
static hetinv_result_t read_header(reader_t *rd, hetinv_optimizer_t *opt, hv_ckpt_fingerprint_t *saved) {
  char magic[8];
  get(rd, magic, 8);
  uint64_t tag = get_u64(rd), version = get_u64(rd);
  /* The checksum before the version: a damaged header is damage, not a
   * newer format; an intact file of another format is unsupported. */
  if (rd->short_read || memcmp(magic, HV_CKPT_MAGIC, 8) != 0) {
    return corrupt(rd, "not a libhetinv checkpoint (bad magic)");
  }
  if (rd->len < rd->at + 8 || hv_fnv1a(HV_FNV_OFFSET, rd->p, rd->len - 8) != stored_checksum(rd)) {
    return corrupt(rd, "damaged: its checksum does not match");
  }
  if (tag != HV_CKPT_BYTE_ORDER_TAG || version < HV_CKPT_FORMAT_OLDEST || version > HV_CKPT_FORMAT_VERSION) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_UNSUPPORTED, "%s: checkpoint format %llu or byte order not supported",
                   rd->name, (unsigned long long)version);
  }
  read_fingerprint(rd, version, saved);
  if (rd->short_read) return corrupt(rd, "truncated in its fingerprint");
  char msg[256];
  const char *diff = fingerprint_diff(rd, opt, saved, msg, sizeof msg);
  if (diff) {
    return HV_FAIL(rd->ctx, HETINV_ERROR_INVALID_ARGUMENT, "%s was written for another run: %s", rd->name,
                   diff);
  }
  if (saved->gain_mode > HETINV_GAIN_PER_EMITTER) {
    return corrupt(rd, "the gain mode is %llu; it must be 0, 1 or 2", (unsigned long long)saved->gain_mode);
  }
  return check_est_params(rd, saved->est_param);
}

/* Leaves the optimizer as before a resume: not started, no stage state. */
static void reset(hetinv_optimizer_t *opt) {
  hv_optimizer_free_stage_arrays(opt);
  hv_free(opt->ctx, opt->losses);
  opt->losses = NULL;
  opt->loss_count = opt->loss_capacity = 0;
  opt->stage = 0;
  opt->stage_iteration = opt->iteration = 0;
  opt->elapsed = 0.0;
}

hetinv_result_t hv_checkpoint_restore(hetinv_optimizer_t *opt, const unsigned char *data, size_t len,
                                      const char *name) {
  reader_t rd = {.ctx = opt->ctx, .name = name, .p = data, .len = len};
  hv_optimizer_resolve_iterations(opt);
  hv_ckpt_fingerprint_t saved;
  hetinv_result_t r = read_header(&rd, opt, &saved);
  if (r != HETINV_SUCCESS) return r;

  position_t at = {.stage = get_u64(&rd), .stage_iteration = get_u64(&rd), .iteration = get_u64(&rd)};
  at.elapsed = get_f64(&rd);
  at.k = get_u64(&rd);
  if (rd.short_read) return corrupt(&rd, "truncated in its state");
  r = check_position(&rd, opt, &at);
  if (r != HETINV_SUCCESS) return r;
  /* The position fixes every length that follows: the file must have
   * exactly that many bytes, before anything is allocated from them. */
  uint64_t want = checkpoint_size(opt, at.k, at.iteration) - rd.older_format_less;
  if ((uint64_t)len != want) {
    return corrupt(&rd, "%zu bytes; a checkpoint of this run at iteration %llu (stage %llu) has %llu", len,
                   (unsigned long long)at.iteration, (unsigned long long)at.stage, (unsigned long long)want);
  }

  reset(opt);
  opt->stage = (int32_t)at.stage;
  r = hv_optimizer_alloc_stage_arrays(opt, (size_t)at.k);
  hetinv_medium_t *base = NULL;
  if (r == HETINV_SUCCESS) {
    get(&rd, opt->pi, opt->k * sizeof(double));
    get(&rd, opt->acc1, opt->k * sizeof(double));
    get(&rd, opt->acc2, opt->k * sizeof(double));
    r = check_in_box(&rd, opt, opt->pi, "pi", -1);
  }
  if (r == HETINV_SUCCESS) r = check_accumulators(&rd, opt);
  if (r == HETINV_SUCCESS) r = read_ring(&rd, opt, at.stage_iteration);
  if (r == HETINV_SUCCESS) r = read_losses(&rd, opt, at.iteration);
  if (r == HETINV_SUCCESS) r = read_base(&rd, opt, &base);
  if (r == HETINV_SUCCESS && (rd.short_read || rd.at + 8 != len)) {
    r = HV_FAIL(rd.ctx, HETINV_ERROR_INTERNAL, "%s: read %zu of %zu bytes", name, rd.at, len - 8);
  }
  if (r != HETINV_SUCCESS) {
    reset(opt);
    return r;
  }
  opt->stage_iteration = (int64_t)at.stage_iteration;
  opt->iteration = (int64_t)at.iteration;
  opt->elapsed = at.elapsed;
  opt->base = base;
  memcpy(opt->est_param, saved.est_param, sizeof opt->est_param);
  opt->verify_est_param = true;
  opt->gain_mode = (hetinv_gain_mode_t)saved.gain_mode;
  opt->verify_gain_mode = rd.has_geometry;
  opt->started = true;
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
  hv_optimizer_resolve_iterations(opt);
  unsigned char *data = NULL;
  size_t len = 0;
  hetinv_result_t r = read_file(opt, path, max_checkpoint_size(opt), &data, &len);
  if (r != HETINV_SUCCESS) return r;
  char name[1024];
  snprintf(name, sizeof name, "'%s'", path);
  r = hv_checkpoint_restore(opt, data, len, name);
  hv_free(ctx, data);
  return r;
}
