/* The optimizer's checkpoints: a child process killed half-way by SIGKILL,
 * resumed in the parent, compared bitwise with an uninterrupted run;
 * refused configurations; damaged files; forged files with a valid
 * checksum, refused field by field; older formats; only regular files read;
 * a checkpoint that cannot be written. The problem: optimize_problem.h,
 * whose one-thread contexts keep fork() safe. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "optimize_problem.h"

/* ------------------------------------------------------------------------ */
/* 1. Checkpoints: kill a run half-way, resume it, compare bitwise. */

static int kill_at(const hetinv_progress_t *progress, void *user) {
  const int64_t *at = user;
  if (progress->iteration == *at) raise(SIGKILL); /* really die: no cleanup, no final checkpoint */
  return 0;
}

/* Runs a configuration with checkpoints to `path` in a child process that
 * kills itself after iteration `at`. The child calls nothing of cmocka and
 * leaves by _exit only. */
static void run_killed_child(const problem_t *p, const setup_t *s, const char *path, int64_t at) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  assert_ok(hetinv_optimizer_set_checkpoint(opt, path));
  assert_ok(hetinv_optimizer_set_progress(opt, kill_at, &at));
  fflush(stdout);
  fflush(stderr);
  pid_t pid = fork();
  assert_true(pid >= 0);
  if (pid == 0) {
    hetinv_optimizer_run(opt, p->est, NULL);
    _exit(3); /* not reached */
  }
  int status = 0;
  assert_int_equal(waitpid(pid, &status, 0), pid);
  if (!(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL)) {
    print_error("the child was not killed by SIGKILL (status %d)\n", status);
    fail();
  }
  hetinv_optimizer_destroy(&opt); /* the parent's copy, never run */
}

/* A fresh optimizer resumes `path`, whose run had `done` iterations, and
 * runs to the end. */
static void resume_and_finish(const problem_t *p, const setup_t *s, const char *path, size_t done,
                              const outcome_t *reference, outcome_t *o) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  assert_ok(hetinv_optimizer_resume(opt, path));
  size_t n = 0;
  const double *loss = hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, done);
  assert_memory_equal(loss, reference->losses, done * sizeof *loss);
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_optimizer_resume(opt, path));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  capture(opt, reference->k, o);
  hetinv_optimizer_destroy(&opt);
}

/* No file but the checkpoint in the directory: every replacement was a rename. */
static void assert_only_checkpoints_left(int expected) {
  assert_int_equal(ht_tmpdir_entry_count(), expected);
  DIR *d = opendir(ht_path("."));
  assert_non_null(d);
  for (struct dirent *e; (e = readdir(d)) != NULL;) assert_null(strstr(e->d_name, ".hetinv-tmp-"));
  closedir(d);
}

static void killed_runs_resume_bitwise(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-kill");
  char path[1024];
  snprintf(path, sizeof path, "%s", ht_path("run.ckpt"));
  outcome_t *o = calloc(2, sizeof *o);
  /* One stage of 8 iterations: checkpoints every 1 or 3 iterations, so the
   * resume starts at the kill (4) or before it (3). */
  static const struct { double interval; int64_t at; size_t done; } one[] = {{1, 4, 4}, {3, 4, 3}};
  setup_t s = coarse_setup(p);
  reference_run(p, &s, 1, &o[0]);
  for (size_t i = 0; i < sizeof one / sizeof one[0]; ++i) {
    s.interval = one[i].interval;
    run_killed_child(p, &s, path, one[i].at);
    resume_and_finish(p, &s, path, one[i].done, &o[0], &o[1]);
    assert_same_outcome(&o[0], &o[1]);
    assert_only_checkpoints_left(1);
  }
  /* Two stages (coarse 4, per voxel 4): the kill at the boundary and inside
   * the second stage. */
  s = two_stage_setup(p);
  reference_run(p, &s, 4, &o[0]);
  static const int64_t two[] = {4, 6};
  for (size_t i = 0; i < sizeof two / sizeof two[0]; ++i) {
    run_killed_child(p, &s, path, two[i]);
    resume_and_finish(p, &s, path, (size_t)two[i], &o[0], &o[1]);
    assert_same_outcome(&o[0], &o[1]);
  }
  /* With minibatches and Adam too. */
  s.minibatch = 1;
  s.method = HETINV_METHOD_ADAM;
  reference_run(p, &s, 4, &o[0]);
  run_killed_child(p, &s, path, 6);
  resume_and_finish(p, &s, path, 6, &o[0], &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  assert_only_checkpoints_left(1);
  free(o);
  ht_tmpdir_remove();
}

/* A checkpoint of the coarse setup stopped after 4 iterations. */
static void write_half_way(const problem_t *p, const setup_t *s, const char *path) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  stopper_t st = {.stop_at = 4};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, path));
  hetinv_optimizer_destroy(&opt);
}

/* A resume into a differently configured optimizer fails naming the
 * difference, and leaves that optimizer as it was. */
static void expect_refused(hetinv_optimizer_t *opt, const char *path, const char *names) {
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, path));
  assert_message_contains(names);
  size_t n = 99;
  assert_null(hetinv_optimizer_losses(opt, &n));
  assert_int_equal(n, 0);
}

/* p's set (optimize_problem.c) with its first beam moved along x, holding
 * p's values; *beam, which the set borrows, is destroyed after it. */
static hetinv_measurements_t *moved_set(const problem_t *p, hetinv_emitter_t **beam) {
  hetinv_measurements_t *set = NULL;
  assert_ok(hetinv_measurements_create(p->ctx, &set));
  assert_ok(hetinv_emitter_create_ideal(p->truth, (double[]){p->beam_x[0] + 0.125, 0.5, -1}, (double[]){0, 0, 1},
                                        beam));
  bool transmit = hetinv_measurements_row_count(p->set) == 2 * p->emitters;
  for (int e = 0; e < p->emitters; ++e) {
    const hetinv_emitter_t *emitter = e == 0 ? *beam : p->beams[e];
    assert_ok(hetinv_measurements_add(set, emitter, p->reflect, p->pathlength, NULL));
    if (transmit) assert_ok(hetinv_measurements_add(set, emitter, p->transmit, p->pathlength, NULL));
  }
  assert_int_equal(hetinv_measurements_value_count(set), p->count);
  assert_ok(hetinv_measurements_set_values(set, hetinv_measurements_values(p->set), NULL, p->count));
  return set;
}

static void resume_refuses_another_configuration(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-refuse");
  char path[1024];
  snprintf(path, sizeof path, "%s", ht_path("half.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, path);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 1, &o[0]);
  hetinv_optimizer_t *opt = NULL;

  /* Tunables, by name. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_ITERATIONS, 12));
  expect_refused(opt, path, "HETINV_OPTIMIZER_ITERATIONS");
  hetinv_optimizer_destroy(&opt);
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_DECAY, 0.9));
  expect_refused(opt, path, "HETINV_OPTIMIZER_DECAY");
  /* ...and the refused optimizer still runs from scratch like a fresh one. */
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_DECAY, 0.95));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  hetinv_optimizer_destroy(&opt);
  /* A stage's own iteration count. */
  setup_t t = s;
  t.iterations[0] = 9;
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stage 0");
  assert_message_contains("iterations 8 vs 9");
  hetinv_optimizer_destroy(&opt);
  /* Fewer iterations: the checkpoint (at iteration 4) is longer than any
   * this run writes, and is refused naming the difference, not its size. */
  t = s;
  t.iterations[0] = 3;
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stage 0");
  assert_message_contains("iterations 8 vs 3");
  hetinv_optimizer_destroy(&opt);
  /* A stage's own starting ε. */
  t = s;
  t.epsilon_start[0] = 0.02;
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stage 0");
  assert_message_contains("epsilon_start");
  hetinv_optimizer_destroy(&opt);
  /* A settling part of more photons (hetinv_stage_t.settle_photons). */
  t = s;
  t.settle_photons[0] = 2.0;
  t.settle_fraction[0] = 0.5;
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stage 0");
  assert_message_contains("settling");
  hetinv_optimizer_destroy(&opt);
  /* Another schedule. */
  t = two_stage_setup(p);
  opt = make_optimizer(p, &t);
  expect_refused(opt, path, "stages");
  hetinv_optimizer_destroy(&opt);
  /* Bounds. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, 1, 11));
  expect_refused(opt, path, "bounds of sigma_s");
  hetinv_optimizer_destroy(&opt);
  /* Measured values (changed while no optimizer uses the set, then restored). */
  double *values = malloc(p->count * sizeof *values);
  memcpy(values, hetinv_measurements_values(p->set), p->count * sizeof *values);
  values[1] *= 1.01;
  assert_ok(hetinv_measurements_set_values(p->set, values, NULL, p->count));
  opt = make_optimizer(p, &s);
  expect_refused(opt, path, "measured values");
  hetinv_optimizer_destroy(&opt);
  values[1] /= 1.01;
  assert_ok(hetinv_measurements_set_values(p->set, values, NULL, p->count));
  /* The loss clip's scales; set back to 1 they hash as a set that never had any. */
  for (size_t i = 0; i < p->count; ++i) values[i] = i == 1 ? 2.0 : 1.0;
  assert_ok(hetinv_measurements_set_clip_scales(p->set, NULL, values, p->count));
  opt = make_optimizer(p, &s);
  expect_refused(opt, path, "clip scales");
  hetinv_optimizer_destroy(&opt);
  values[1] = 1.0;
  assert_ok(hetinv_measurements_set_clip_scales(p->set, values, values, p->count));
  free(values);
  /* Initial medium. */
  hetinv_medium_t *other = make_medium(p->ctx, p->dims, 7.0);
  assert_ok(hetinv_medium_commit(other));
  assert_ok(hetinv_optimizer_create(p->ctx, p->set, other, &opt));
  assert_ok(configure(opt, &s));
  expect_refused(opt, path, "initial medium");
  hetinv_optimizer_destroy(&opt);
  hetinv_medium_destroy(&other);
  /* Seed. */
  hetinv_context_t *ctx2 = make_context(8);
  assert_ok(hetinv_optimizer_create(ctx2, p->set, p->initial, &opt));
  assert_ok(configure(opt, &s));
  expect_refused(opt, path, "seed");
  hetinv_optimizer_destroy(&opt);
  hetinv_context_destroy(&ctx2);
  /* The same values under another geometry: the first beam moved. */
  hetinv_emitter_t *beam = NULL;
  hetinv_measurements_t *moved = moved_set(p, &beam);
  assert_ok(hetinv_optimizer_create(p->ctx, moved, p->initial, &opt));
  assert_ok(configure(opt, &s));
  expect_refused(opt, path, "measurement geometry differs");
  hetinv_optimizer_destroy(&opt);
  hetinv_measurements_destroy(&moved);
  hetinv_emitter_destroy(&beam);
  /* ...or the reflection camera tilted (its kind's own fingerprint). */
  hetinv_sensor_t *tilted = NULL;
  const double *pixel = p->dims[0] == 3 ? (double[]){1.0 / 3, 1} : (double[]){0.5, 1};
  assert_ok(hetinv_sensor_create_orthographic(p->truth, HETINV_FACE_Z_MIN, (double[]){0.1, 0, -1}, (double[]){0, 0},
                                              pixel, p->dims[0] == 3 ? 3 : 2, 1, &tilted));
  assert_ok(hetinv_measurements_create(p->ctx, &moved));
  for (int e = 0; e < p->emitters; ++e) {
    assert_ok(hetinv_measurements_add(moved, p->beams[e], tilted, p->pathlength, NULL));
    if (hetinv_measurements_row_count(p->set) == 2 * p->emitters) {
      assert_ok(hetinv_measurements_add(moved, p->beams[e], p->transmit, p->pathlength, NULL));
    }
  }
  assert_ok(hetinv_measurements_set_values(moved, hetinv_measurements_values(p->set), NULL, p->count));
  assert_ok(hetinv_optimizer_create(p->ctx, moved, p->initial, &opt));
  assert_ok(configure(opt, &s));
  expect_refused(opt, path, "measurement geometry differs");
  hetinv_optimizer_destroy(&opt);
  hetinv_measurements_destroy(&moved);
  hetinv_sensor_destroy(&tilted);

  /* The estimator's tunables and gain mode are checked when the resumed
   * run starts. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_resume(opt, path));
  assert_ok(hetinv_estimator_set_gain_mode(p->est, HETINV_GAIN_GLOBAL));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_run(opt, p->est, NULL));
  assert_message_contains("gain mode is HETINV_GAIN_GLOBAL; the checkpointed run used HETINV_GAIN_NONE");
  assert_ok(hetinv_estimator_set_gain_mode(p->est, HETINV_GAIN_NONE));
  hetinv_optimizer_destroy(&opt);
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_resume(opt, path));
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 300));
  hetinv_stop_reason_t why = HETINV_STOP_NONE;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_run(opt, p->est, &why));
  assert_message_contains("HETINV_ESTIMATOR_PHOTONS");
  assert_message_contains("300");
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 4);
  /* With the right estimator, the run continues as if never stopped. */
  assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_PHOTONS, 100));
  assert_ok(hetinv_optimizer_run(opt, p->est, &why));
  assert_int_equal(why, HETINV_STOP_COMPLETED);
  capture(opt, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  hetinv_optimizer_destroy(&opt);
  free(o);
  ht_tmpdir_remove();
}

static uint64_t fnv1a64(const unsigned char *p, size_t n) {
  uint64_t h = UINT64_C(0xcbf29ce484222325);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * UINT64_C(0x100000001b3);
  return h;
}

static unsigned char *slurp(const char *path, size_t *len) {
  FILE *f = fopen(path, "rb");
  assert_non_null(f);
  fseek(f, 0, SEEK_END);
  long size = ftell(f);
  assert_true(size > 0);
  fseek(f, 0, SEEK_SET);
  unsigned char *data = malloc((size_t)size);
  assert_int_equal(fread(data, 1, (size_t)size, f), (size_t)size);
  fclose(f);
  *len = (size_t)size;
  return data;
}

/* A damaged file is refused as corrupt and changes nothing. */
static void expect_corrupt(hetinv_optimizer_t *opt, const char *path) {
  hetinv_result_t r = hetinv_optimizer_resume(opt, path);
  if (r != HETINV_ERROR_CORRUPT_FILE) {
    print_error("resume returned %s (%s)\n", hetinv_result_name(r), hetinv_context_last_error_message(NULL));
    fail();
  }
  assert_null(hetinv_optimizer_losses(opt, NULL));
}

static void damaged_checkpoints_are_refused(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-corrupt");
  char good[1024], bad[1024];
  snprintf(good, sizeof good, "%s", ht_path("good.ckpt"));
  snprintf(bad, sizeof bad, "%s", ht_path("bad.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, good);
  size_t len = 0;
  unsigned char *data = slurp(good, &len);
  unsigned char *copy = malloc(len + 1);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 1, &o[0]);
  hetinv_optimizer_t *opt = make_optimizer(p, &s);

  /* Truncated anywhere, or one byte too long. */
  const size_t cuts[] = {0, 1, 7, 8, 16, 23, 24, 25, 100, len / 2, len - 9, len - 8, len - 1};
  for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; ++i) {
    ht_write_file(bad, data, cuts[i]);
    expect_corrupt(opt, bad);
  }
  memcpy(copy, data, len);
  copy[len] = 0;
  ht_write_file(bad, copy, len + 1);
  expect_corrupt(opt, bad);
  /* One bit flipped: every byte of the header and the start of the
   * fingerprint, then bytes spread over the fingerprint and the state, and
   * every byte of the last value and the checksum. */
  for (size_t i = 0; i < len; i += i < 64 || i >= len - 16 ? 1 : 29) {
    memcpy(copy, data, len);
    copy[i] ^= (unsigned char)(1u << (i % 8));
    ht_write_file(bad, copy, len);
    expect_corrupt(opt, bad);
  }
  /* Another magic, even with a valid checksum. */
  memcpy(copy, data, len);
  memcpy(copy, "HVCKPT99", 8);
  uint64_t sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(bad, copy, len);
  expect_corrupt(opt, bad);
  assert_message_contains("magic");
  ht_write_file(bad, "not a checkpoint at all, just text.", 35);
  expect_corrupt(opt, bad);
  /* An intact file of a later or an earlier format version is
   * unsupported, not corrupt. */
  memcpy(copy, data, len);
  uint64_t version = 1000;
  memcpy(copy + 16, &version, 8);
  sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(bad, copy, len);
  assert_result(HETINV_ERROR_UNSUPPORTED, hetinv_optimizer_resume(opt, bad));
  version = 1;
  memcpy(copy + 16, &version, 8);
  sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(bad, copy, len);
  assert_result(HETINV_ERROR_UNSUPPORTED, hetinv_optimizer_resume(opt, bad));
  assert_message_contains("format 1");
  /* Intact (checksummed) files whose content is inconsistent: a loss
   * history far larger than the file, an averaging ring fuller than its
   * window, a negative σs in the base medium. The tail of the file holds
   * ... ring (3 x 1), loss count, 4 losses, 3 grids of 4 voxels, checksum. */
  const size_t grids = len - 8 - 3 * 4 * 8, loss_count = grids - 4 * 8 - 8;
  const size_t ring_count = loss_count - 3 * 8 - 2 * 8, iteration = loss_count - 96;
  uint64_t field[3];
  memcpy(&field[0], data + iteration, 8);
  memcpy(&field[1], data + loss_count, 8);
  memcpy(&field[2], data + ring_count, 8);
  assert_true(field[0] == 4 && field[1] == 4 && field[2] == 3); /* the layout is as read here */
  const struct { size_t at[2]; uint64_t u; double d; } forged[] = {
      {{iteration, loss_count}, UINT64_C(1) << 40, 0}, /* would allocate 8 TiB */
      {{iteration, loss_count}, 5, 0},
      {{ring_count, ring_count}, 4, 0},
      {{grids + 4 * 8 + 8, grids + 4 * 8 + 8}, 0, -1.0}, /* σs of voxel 1 */
      {{grids + 2 * 4 * 8, grids + 2 * 4 * 8}, 0, 1.5},   /* g of voxel 0 */
  };
  for (size_t i = 0; i < sizeof forged / sizeof forged[0]; ++i) {
    memcpy(copy, data, len);
    for (int j = 0; j < 2; ++j) {
      if (forged[i].d != 0) {
        memcpy(copy + forged[i].at[j], &forged[i].d, 8);
      } else {
        memcpy(copy + forged[i].at[j], &forged[i].u, 8);
      }
    }
    sum = fnv1a64(copy, len - 8);
    memcpy(copy + len - 8, &sum, 8);
    ht_write_file(bad, copy, len);
    expect_corrupt(opt, bad);
  }
  /* Missing files are I/O errors. */
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_resume(opt, ht_path("missing.ckpt")));
  assert_message_contains("missing.ckpt");

  /* After all that, the optimizer runs from scratch like a fresh one... */
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  capture(opt, 1, &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  hetinv_optimizer_destroy(&opt);
  /* ...and the intact file resumes to the same end. */
  resume_and_finish(p, &s, good, 4, &o[0], &o[1]);
  assert_same_outcome(&o[0], &o[1]);
  free(o);
  free(copy);
  free(data);
  ht_tmpdir_remove();
}

/* Forged checkpoints: intact (checksum recomputed) but holding a state
 * the configured run cannot be in. Each is refused as corrupt, naming the
 * field, before anything is used or allocated from it. */

/* Offsets of the state fields of a checkpoint of the coarse setup (k = 1,
 * window 3) stopped after 4 iterations: from the end, checksum, 3 grids of
 * 4 voxels, 4 losses, their count, the ring (3 x 1), head, count, window,
 * acc2, acc1, π, k, elapsed, iteration, stage iteration, stage. */
typedef struct layout {
  size_t stage, stage_it, it, elapsed, k, pi, acc1, acc2, window, count, head, ring, losses_n, losses, grids;
  size_t est; /* the estimator's tunables in the fingerprint */
} layout_t;

static layout_t coarse_layout(size_t len) {
  layout_t l;
  l.grids = len - 8 - 3 * 4 * 8;
  l.losses = l.grids - 4 * 8;
  l.losses_n = l.losses - 8;
  l.ring = l.losses_n - 3 * 8;
  l.head = l.ring - 8;
  l.count = l.head - 8;
  l.window = l.count - 8;
  l.acc2 = l.window - 8;
  l.acc1 = l.acc2 - 8;
  l.pi = l.acc1 - 8;
  l.k = l.pi - 8;
  l.elapsed = l.k - 8;
  l.it = l.elapsed - 8;
  l.stage_it = l.it - 8;
  l.stage = l.stage_it - 8;
  l.est = 24 + 8 * (4 + 3 * 64 + HETINV_OPTIMIZER_PARAM_COUNT_ + 2 * HETINV_PARAM_COUNT);
  return l;
}

typedef struct forgery {
  const char *what;   /* in the expected message */
  size_t *at[3];      /* up to three fields set to the value */
  bool is_double;
  uint64_t u;
  double d;
} forgery_t;

/* Writes `data` with the forgery applied and the checksum recomputed. */
static void write_forged(const char *path, const unsigned char *data, size_t len, unsigned char *copy,
                         const forgery_t *f) {
  memcpy(copy, data, len);
  for (int j = 0; j < 3 && f->at[j]; ++j) {
    if (f->is_double) {
      memcpy(copy + *f->at[j], &f->d, 8);
    } else {
      memcpy(copy + *f->at[j], &f->u, 8);
    }
  }
  uint64_t sum = fnv1a64(copy, len - 8);
  memcpy(copy + len - 8, &sum, 8);
  ht_write_file(path, copy, len);
}

/* Resumes a forged file into a fresh optimizer: true when it is refused as
 * corrupt with `what` in the message and the optimizer left empty. */
static bool refused_field(const problem_t *p, const setup_t *s, const char *path, const char *what) {
  hetinv_optimizer_t *opt = make_optimizer(p, s);
  hetinv_result_t r = hetinv_optimizer_resume(opt, path);
  const char *m = hetinv_context_last_error_message(NULL);
  bool ok = r == HETINV_ERROR_CORRUPT_FILE && strstr(m, what) != NULL && hetinv_optimizer_losses(opt, NULL) == NULL;
  if (!ok) print_error("forged '%s': resume returned %s (%s)\n", what, hetinv_result_name(r), r ? m : "accepted");
  hetinv_optimizer_destroy(&opt);
  return ok;
}

static void forged_checkpoints_are_refused(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-forged");
  char good[1024], bad[1024];
  snprintf(good, sizeof good, "%s", ht_path("good.ckpt"));
  snprintf(bad, sizeof bad, "%s", ht_path("bad.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, good);
  size_t len = 0;
  unsigned char *data = slurp(good, &len);
  unsigned char *copy = malloc(len);
  layout_t l = coarse_layout(len);
  /* The layout is as read here: stage 0, iteration 4 of 4, k 1, window 3
   * holding 3 iterates with its head at 4 mod 3, 100 photons. */
  uint64_t u[8];
  size_t at[] = {l.stage, l.stage_it, l.it, l.k, l.window, l.count, l.head, l.losses_n};
  for (int i = 0; i < 8; ++i) memcpy(&u[i], data + at[i], 8);
  assert_true(u[0] == 0 && u[1] == 4 && u[2] == 4 && u[3] == 1 && u[4] == 3 && u[5] == 3 && u[6] == 1 && u[7] == 4);
  double photons = 0;
  memcpy(&photons, data + l.est + 8 * HETINV_ESTIMATOR_PHOTONS, 8);
  assert_true(photons == 100);
  size_t est_photons = l.est + 8 * HETINV_ESTIMATOR_PHOTONS, sigma_s1 = l.grids + 4 * 8 + 8, sigma_a1 = l.grids + 8;
  size_t ring1 = l.ring + 8, ring2 = l.ring + 16;
  size_t gain_mode = l.est + 8 * HETINV_ESTIMATOR_PARAM_COUNT_ + 4 * 8;

  const forgery_t forged[] = {
      {"the stage is 1", {&l.stage}, false, 1, 0},
      {"the stage iteration is 9; stage 0 has 8", {&l.stage_it}, false, 9, 0},
      {"the stage iteration is 9223372036854775808", {&l.stage_it}, false, UINT64_C(1) << 63, 0},
      {"the iteration is 3", {&l.it}, false, 3, 0},
      {"the iteration is 1099511627776", {&l.it, &l.losses_n}, false, UINT64_C(1) << 40, 0},
      {"bytes; a checkpoint of this run at iteration 5 (stage 0) has", {&l.stage_it, &l.it, &l.losses_n}, false, 5, 0},
      {"stage 0 has 2 entries", {&l.k}, false, 2, 0},
      {"the elapsed time is nan", {&l.elapsed}, true, 0, NaN},
      {"the elapsed time is -1", {&l.elapsed}, true, 0, -1},
      {"pi[0] is 130442; its bounds are [1, 10]", {&l.pi}, true, 0, 130442},
      {"pi[0] is 0.5", {&l.pi}, true, 0, 0.5},
      {"pi[0] is nan", {&l.pi}, true, 0, NaN},
      {"accumulator 1 of entry 0 is nan", {&l.acc1}, true, 0, NaN},
      {"accumulator 1 of entry 0 is -1", {&l.acc1}, true, 0, -1},
      {"accumulator 2 of entry 0 is inf", {&l.acc2}, true, 0, Inf},
      {"accumulator 2 of entry 0 is -1e-300", {&l.acc2}, true, 0, -1e-300},
      {"the averaging window is 4", {&l.window}, false, 4, 0},
      {"the averaging ring holds 2 iterates", {&l.count}, false, 2, 0},
      {"its head is 0", {&l.head}, false, 0, 0},
      {"its head is 4611686018427387904", {&l.head}, false, UINT64_C(1) << 62, 0},
      {"pi[0] (iterate 1 of the averaging ring) is 130442", {&ring1}, true, 0, 130442},
      {"pi[0] (iterate 2 of the averaging ring) is nan", {&ring2}, true, 0, NaN},
      {"the loss history has 5 losses", {&l.losses_n}, false, 5, 0},
      {"loss 0 is -1", {&l.losses}, true, 0, -1},
      {"loss 0 is nan", {&l.losses}, true, 0, NaN},
      {"sigma_s of voxel 1 is -1", {&sigma_s1}, true, 0, -1},
      {"sigma_s of voxel 1 is 7 in stage 0; no earlier stage frees sigma_s, and the initial medium's is 8", {&sigma_s1}, true, 0, 7},
      {"sigma_a of voxel 1 is 1e+223", {&sigma_a1}, true, 0, 1e223},
      {"HETINV_ESTIMATOR_PHOTONS is 0", {&est_photons}, true, 0, 0},
      {"HETINV_ESTIMATOR_PHOTONS is nan", {&est_photons}, true, 0, NaN},
      {"the gain mode is 3; it must be 0, 1 or 2", {&gain_mode}, false, 3, 0},
  };
  int failures = 0;
  for (size_t i = 0; i < sizeof forged / sizeof forged[0]; ++i) {
    write_forged(bad, data, len, copy, &forged[i]);
    failures += !refused_field(p, &s, bad, forged[i].what);
  }
  /* The intact file still resumes. */
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_resume(opt, good));
  hetinv_optimizer_destroy(&opt);

  /* With a plateau window of 3, a stage iteration of 7 after 4 iterations
   * in all would make the plateau test read 2 losses before the history. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 3));
  stopper_t st = {.stop_at = 4};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, good));
  hetinv_optimizer_destroy(&opt);
  free(data);
  data = slurp(good, &len);
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_PLATEAU_WINDOW, 3));
  const forgery_t seven = {"the iteration is 4; at iteration 7 of stage 0 it must be in [7, 7]", {&l.stage_it}, false, 7, 0};
  write_forged(bad, data, len, copy, &seven);
  if (hetinv_optimizer_resume(opt, bad) == HETINV_SUCCESS) {
    print_error("forged '%s': accepted; running it:\n", seven.what);
    hetinv_optimizer_run(opt, p->est, NULL); /* shows the harm (under ASan) */
    ++failures;
  } else {
    assert_message_contains(seven.what);
  }
  hetinv_optimizer_destroy(&opt);

  /* In stage 1 of two (coarse, then per voxel), σs was freed by stage 0:
   * inside its bounds; σa was not: the initial medium's. */
  setup_t two = two_stage_setup(p);
  opt = make_optimizer(p, &two);
  st = (stopper_t){.stop_at = 6};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, good));
  hetinv_optimizer_destroy(&opt);
  free(data);
  data = slurp(good, &len);
  free(copy);
  copy = malloc(len); /* a larger file: 4 entries */
  size_t grids = len - 8 - 3 * 4 * 8;
  size_t two_sigma_a0 = grids, two_sigma_s2 = grids + 4 * 8 + 2 * 8;
  double v = 0;
  memcpy(&v, data + two_sigma_s2, 8);
  assert_true(v >= SIGMA_LO && v <= SIGMA_HI && v != START_SIGMA_S); /* the layout is as read here */
  const forgery_t stage1[] = {
      {"sigma_s of voxel 2 is 130442; its bounds are [1, 10]", {&two_sigma_s2}, true, 0, 130442},
      {"sigma_s of voxel 2 is 0.5; its bounds are [1, 10]", {&two_sigma_s2}, true, 0, 0.5},
      {"sigma_a of voxel 0 is 0.5 in stage 1; no earlier stage frees sigma_a", {&two_sigma_a0}, true, 0, 0.5},
  };
  for (size_t i = 0; i < sizeof stage1 / sizeof stage1[0]; ++i) {
    write_forged(bad, data, len, copy, &stage1[i]);
    failures += !refused_field(p, &two, bad, stage1[i].what);
  }
  opt = make_optimizer(p, &two);
  assert_ok(hetinv_optimizer_resume(opt, good));
  hetinv_optimizer_destroy(&opt);

  /* With σs in [1, ∞), π = ∞ is inside the bounds but not a value. */
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, Inf));
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  st.calls = 0;
  assert_ok(hetinv_optimizer_run(opt, p->est, NULL));
  assert_ok(hetinv_optimizer_save(opt, good));
  hetinv_optimizer_destroy(&opt);
  free(data);
  data = slurp(good, &len);
  const forgery_t infinite = {"pi[0] is inf; its bounds are [1, inf]", {&l.pi}, true, 0, Inf};
  write_forged(bad, data, len, copy, &infinite);
  opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_bounds(opt, HETINV_PARAM_SIGMA_S, SIGMA_LO, Inf));
  hetinv_result_t r = hetinv_optimizer_resume(opt, bad);
  if (r != HETINV_ERROR_CORRUPT_FILE) {
    print_error("forged '%s': resume returned %s\n", infinite.what, hetinv_result_name(r));
    ++failures;
  } else {
    assert_message_contains(infinite.what);
  }
  hetinv_optimizer_destroy(&opt);
  free(copy);
  free(data);
  ht_tmpdir_remove();
  assert_int_equal(failures, 0);
}

/* The checkpoint at `data` rewritten in an older format: version 6 lacks
 * the set's geometry hash and the gain mode at the fingerprint's end,
 * version 5 also HETINV_OPTIMIZER_BOX_MARGIN in its tunables, version 4
 * also HETINV_OPTIMIZER_MULTISCALE, version 3 also
 * HETINV_OPTIMIZER_SMOOTHNESS (the last of the list each time), version 2
 * also HETINV_ESTIMATOR_LOSS_CLIP in its estimator tunables (the last of
 * its list). Returns the new length. */
static size_t older_format(const unsigned char *data, size_t len, uint64_t version, unsigned char *out) {
  layout_t l = coarse_layout(len);
  int first = version == 6   ? HETINV_OPTIMIZER_PARAM_COUNT_
              : version == 5 ? HETINV_OPTIMIZER_BOX_MARGIN
              : version == 4 ? HETINV_OPTIMIZER_MULTISCALE
                             : HETINV_OPTIMIZER_SMOOTHNESS; /* the first tunable it lacks */
  /* Cuts in increasing order: tunables, the estimator's LOSS_CLIP, and
   * after the estimator's tunables and three hashes, the geometry hash and
   * gain mode. */
  size_t cut[3] = {24 + 8 * (4 + 3 * 64 + (size_t)first), l.est + 8 * HETINV_ESTIMATOR_LOSS_CLIP,
                   l.est + 8 * HETINV_ESTIMATOR_PARAM_COUNT_ + 3 * 8};
  size_t bytes[3] = {8 * (size_t)(HETINV_OPTIMIZER_PARAM_COUNT_ - first), version == 2 ? 8 : 0, 16};
  size_t n = 0, from = 0;
  for (int c = 0; c < 3; ++c) {
    memcpy(out + n, data + from, cut[c] - from);
    n += cut[c] - from;
    from = cut[c] + bytes[c];
  }
  memcpy(out + n, data + from, len - from);
  n += len - from;
  memcpy(out + 16, &version, 8);
  uint64_t sum = fnv1a64(out, n - 8);
  memcpy(out + n - 8, &sum, 8);
  return n;
}

/* Checkpoints of formats 2 to 6 (before HETINV_ESTIMATOR_LOSS_CLIP,
 * HETINV_OPTIMIZER_SMOOTHNESS, HETINV_OPTIMIZER_MULTISCALE,
 * HETINV_OPTIMIZER_BOX_MARGIN and the geometry hash: fewer fields in the
 * fingerprint) resume as least squares without a prior, a multi-scale
 * step or a margin and finish as the uninterrupted run; under a clipped
 * loss (formats 2), a prior (2, 3), a multi-scale step (2-4) or a margin
 * (2-5) they are refused; another geometry is not seen. */
static void older_format_checkpoints_resume(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-older-formats");
  char path[1024], old[1024];
  snprintf(path, sizeof path, "%s", ht_path("run.ckpt"));
  snprintf(old, sizeof old, "%s", ht_path("old.ckpt"));
  setup_t s = coarse_setup(p);
  write_half_way(p, &s, path);
  size_t len = 0;
  unsigned char *data = slurp(path, &len);
  unsigned char *older = malloc(len);
  assert_non_null(older);
  outcome_t *o = calloc(2, sizeof *o);
  reference_run(p, &s, 1, &o[0]);
  for (uint64_t version = 2; version <= 6; ++version) {
    ht_write_file(old, older, older_format(data, len, version, older));
    resume_and_finish(p, &s, old, 4, &o[0], &o[1]);
    assert_same_outcome(&o[0], &o[1]);
    hetinv_optimizer_t *opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_resume(opt, old));
    assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_LOSS_CLIP, 3.0));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_run(opt, p->est, NULL));
    assert_message_contains("HETINV_ESTIMATOR_LOSS_CLIP is 3; the checkpointed run used 0");
    assert_ok(hetinv_estimator_set_param(p->est, HETINV_ESTIMATOR_LOSS_CLIP, 0.0));
    hetinv_optimizer_destroy(&opt);
    opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_SMOOTHNESS, 2.0));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, old));
    assert_message_contains("HETINV_OPTIMIZER_SMOOTHNESS is 0 in the checkpoint and 2 here");
    hetinv_optimizer_destroy(&opt);
    opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_MULTISCALE, 0.5));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, old));
    assert_message_contains("HETINV_OPTIMIZER_MULTISCALE is 0 in the checkpoint and 0.5 here");
    hetinv_optimizer_destroy(&opt);
    opt = make_optimizer(p, &s);
    assert_ok(hetinv_optimizer_set_param(opt, HETINV_OPTIMIZER_BOX_MARGIN, 0.25));
    assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_optimizer_resume(opt, old));
    assert_message_contains("HETINV_OPTIMIZER_BOX_MARGIN is 0 in the checkpoint and 0.25 here");
    hetinv_optimizer_destroy(&opt);
    /* Without a geometry hash or a gain mode, neither can be checked. */
    hetinv_emitter_t *beam = NULL;
    hetinv_measurements_t *moved = moved_set(p, &beam);
    assert_ok(hetinv_optimizer_create(p->ctx, moved, p->initial, &opt));
    assert_ok(configure(opt, &s));
    assert_ok(hetinv_optimizer_resume(opt, old));
    hetinv_optimizer_destroy(&opt);
    hetinv_measurements_destroy(&moved);
    hetinv_emitter_destroy(&beam);
  }
  free(o);
  free(older);
  free(data);
  ht_tmpdir_remove();
}

/* The base-medium check does not refuse a real run: after a coarse stage
 * that interpolates (2 x 1 x 2 cells over 3 x 1 x 3 voxels), a checkpoint of
 * the next stage resumes. */
static void interpolated_base_media_resume(void **state) {
  (void)state;
  problem_t p;
  problem_init(&p, 5, 3, 3, 2, false);
  ht_tmpdir_create("optimizer-interpolated");
  char path[1024];
  snprintf(path, sizeof path, "%s", ht_path("stage1.ckpt"));
  hetinv_param_map_t *coarse = NULL;
  assert_ok(hetinv_param_map_create_coarse(p.initial, (int32_t[]){2, 1, 2}, SS, &coarse));
  setup_t s = {.stages = 2, .maps = {coarse, p.identity}, .iterations = {3, 3}, .method = HETINV_METHOD_ADADELTA,
               .minibatch = 0, .window = 3, .interval = 1};
  hetinv_optimizer_t *opt = make_optimizer(&p, &s);
  stopper_t st = {.stop_at = 4};
  assert_ok(hetinv_optimizer_set_progress(opt, stop_at, &st));
  assert_ok(hetinv_optimizer_run(opt, p.est, NULL));
  assert_int_equal(st.last.stage, 1);
  assert_ok(hetinv_optimizer_save(opt, path));
  hetinv_optimizer_destroy(&opt);
  opt = make_optimizer(&p, &s);
  assert_ok(hetinv_optimizer_resume(opt, path));
  hetinv_optimizer_destroy(&opt);
  hetinv_param_map_destroy(&coarse);
  ht_tmpdir_remove();
  problem_release(&p);
}

/* Only regular files are read, and none larger than the configured run
 * can write. */
static void only_regular_checkpoint_files_are_read(void **state) {
  const problem_t *p = *state;
  ht_tmpdir_create("optimizer-notfile");
  setup_t s = coarse_setup(p);
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  /* A directory (ftell would report LLONG_MAX). */
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_resume(opt, ht_path(".")));
  assert_message_contains("not a regular file");
  /* A sparse 64 GiB file: refused from its size, before anything is
   * allocated or read. */
  char big[1024], fifo[1024];
  snprintf(big, sizeof big, "%s", ht_path("big.ckpt"));
  FILE *f = fopen(big, "wb");
  assert_non_null(f);
  assert_int_equal(ftruncate(fileno(f), (off_t)1 << 36), 0);
  fclose(f);
  assert_result(HETINV_ERROR_CORRUPT_FILE, hetinv_optimizer_resume(opt, big));
  assert_message_contains("68719476736 bytes; a checkpoint of this run has at most");
  unlink(big);
  /* A FIFO (whose open would wait for a writer). */
  snprintf(fifo, sizeof fifo, "%s", ht_path("fifo.ckpt"));
  assert_int_equal(mkfifo(fifo, 0600), 0);
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_resume(opt, fifo));
  assert_message_contains("not a regular file");
  unlink(fifo);
  assert_null(hetinv_optimizer_losses(opt, NULL));
  hetinv_optimizer_destroy(&opt);
  ht_tmpdir_remove();
}

/* A checkpoint that cannot be written fails the run with an I/O error. */
static void unwritable_checkpoints_fail_the_run(void **state) {
  const problem_t *p = *state;
  setup_t s = coarse_setup(p);
  hetinv_optimizer_t *opt = make_optimizer(p, &s);
  assert_ok(hetinv_optimizer_set_checkpoint(opt, "/nonexistent/dir/x.ckpt"));
  hetinv_stop_reason_t why = 42;
  assert_result(HETINV_ERROR_IO, hetinv_optimizer_run(opt, p->est, &why));
  assert_message_contains("/nonexistent/dir/x.ckpt");
  size_t n = 0;
  hetinv_optimizer_losses(opt, &n);
  assert_int_equal(n, 1);
  hetinv_optimizer_destroy(&opt);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(killed_runs_resume_bitwise),
      cmocka_unit_test(resume_refuses_another_configuration),
      cmocka_unit_test(damaged_checkpoints_are_refused),
      cmocka_unit_test(forged_checkpoints_are_refused),
      cmocka_unit_test(older_format_checkpoints_resume),
      cmocka_unit_test(only_regular_checkpoint_files_are_read),
      cmocka_unit_test(interpolated_base_media_resume),
      cmocka_unit_test(unwritable_checkpoints_fail_the_run),
  };
  return cmocka_run_group_tests(tests, problem_setup, problem_teardown);
}
