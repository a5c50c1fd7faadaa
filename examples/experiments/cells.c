/* Finished experiment cells as small CSV files (cells.h). */
#include "cells.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Appends printf-style text to the key (truncated at key_size, as snprintf). */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static void key_append(char *key, size_t key_size, const char *fmt, ...) {
  size_t len = strlen(key);
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(key + len, key_size - len, fmt, ap);
  va_end(ap);
}

bool experiment_cell_key(const recon_scene_t *sc, char *key, size_t key_size) {
  /* %.17g: the key is equal only for bitwise-equal settings. */
  snprintf(key, key_size,
           "config=%d grid=%dx%dx%d size=%.17g eta=%.17g truth_seed=%llu noise_seed=%llu "
           "truth=%.17g:%.17g,%.17g:%.17g,%.17g:%.17g bounds=%.17g:%.17g,%.17g:%.17g,%.17g:%.17g "
           "pixels_per_voxel=%d bin_width=%.17g iterations=%lld photons=%lld truth_photons=%lld seed=%llu "
           "weighting=%d",
           (int)sc->config, (int)sc->grid[0], (int)sc->grid[1], (int)sc->grid[2], sc->size, sc->eta,
           (unsigned long long)sc->truth_seed, (unsigned long long)sc->noise_model.seed, sc->truth_lo[0],
           sc->truth_hi[0], sc->truth_lo[1], sc->truth_hi[1], sc->truth_lo[2], sc->truth_hi[2], sc->bounds_lo[0],
           sc->bounds_hi[0], sc->bounds_lo[1], sc->bounds_hi[1], sc->bounds_lo[2], sc->bounds_hi[2],
           (int)sc->pixels_per_voxel, sc->bin_width, (long long)sc->iterations, (long long)sc->photons,
           (long long)sc->truth_photons, (unsigned long long)sc->seed, sc->weighting);
  /* Settings added later appear only when not at their default, so cells
   * stored before them stay valid. */
  if (sc->init_at_truth) {
    key_append(key, key_size, " init=truth levels=%d", (int)sc->levels[sc->level_count - 1]);
  }
  if (sc->levels_keyed) {
    key_append(key, key_size, " levels=");
    for (int32_t l = 0; l < sc->level_count; ++l) key_append(key, key_size, "%s%d", l ? "," : "", (int)sc->levels[l]);
  }
  if (sc->init_keyed) key_append(key, key_size, " init=%.17g:%.17g:%.17g", sc->init[0], sc->init[1], sc->init[2]);
  /* Against the values of the key's first version, not today's defaults:
   * a default that changes must change the key of the cells it computes. */
  if (sc->minibatch != 16) {
    key_append(key, key_size, " minibatch=%d", (int)sc->minibatch);
  }
  /* Cells stored before min_snr existed left nothing out: min_snr 0. */
  if (sc->min_snr != 0.0) {
    key_append(key, key_size, " min_snr=%.17g", sc->min_snr);
  }
  if (sc->min_snr_errors != RECON_SNR_DATA) {
    key_append(key, key_size, " min_snr_errors=%s", recon_snr_errors_names[sc->min_snr_errors]);
  }
  if (sc->epsilon != 0.003) {
    key_append(key, key_size, " epsilon=%.17g", sc->epsilon);
  }
  if (sc->coarse_average_window != 0) {
    key_append(key, key_size, " coarse_average_window=%d", (int)sc->coarse_average_window);
  }
  if (sc->independent_errors) {
    key_append(key, key_size, " independent_errors=1");
  }
  if (sc->pooled_errors) {
    key_append(key, key_size, " pooled_errors=1");
  }
  if (sc->expected_camera_errors) {
    key_append(key, key_size, " expected_camera_errors=1");
  }
  if (sc->smoothness != 0.0) {
    key_append(key, key_size, " smoothness=%.17g", sc->smoothness);
  }
  if (sc->multiscale != 0.0) {
    key_append(key, key_size, " multiscale=%.17g", sc->multiscale);
  }
  if (sc->box_margin != 0.0) {
    key_append(key, key_size, " box_margin=%.17g", sc->box_margin);
  }
  if (sc->loss_clip != 0.0) {
    key_append(key, key_size, " loss_clip=%.17g", sc->loss_clip);
  }
  if (sc->loss_clip_errors != RECON_CLIP_DATA) {
    key_append(key, key_size, " loss_clip_errors=%s", recon_clip_errors_names[sc->loss_clip_errors]);
  }
  if (sc->epsilon_start != 0.0) {
    key_append(key, key_size, " epsilon_start=%.17g", sc->epsilon_start);
  }
  if (sc->coarse_epsilon_start != 0.0) {
    key_append(key, key_size, " coarse_epsilon_start=%.17g", sc->coarse_epsilon_start);
  }
  if (sc->settle_epsilon != 0.0) {
    key_append(key, key_size, " settle_epsilon=%.17g settle_fraction=%.17g", sc->settle_epsilon, sc->settle_fraction);
  }
  if (sc->settle_photons != 0.0) { /* after settle_epsilon's, so the keys of cells without it stand */
    key_append(key, key_size, " settle_photons=%.17g settle_fraction=%.17g", sc->settle_photons, sc->settle_fraction);
  }
  if (sc->coordinates != HETINV_COORDINATES_NATIVE) {
    key_append(key, key_size, " coordinates=%s", recon_coordinate_names[sc->coordinates]);
  }
  /* The optimizer's settings enter the key only where they differ from the
   * scene's defaults, so that cells run before an option existed read back. */
  recon_scene_t d;
  recon_scene_default(&d);
  if (sc->method != d.method || sc->decay != d.decay || sc->coarse_fraction != d.coarse_fraction ||
      sc->average_window != d.average_window || sc->learning_rate != d.learning_rate) {
    key_append(key, key_size, " method=%d decay=%.17g coarse_fraction=%.17g average_window=%lld rate=%.17g",
             (int)sc->method, sc->decay, sc->coarse_fraction, (long long)sc->average_window, sc->learning_rate);
  }
  if (sc->method == HETINV_METHOD_ADAM && (sc->beta1 != d.beta1 || sc->beta2 != d.beta2)) {
    key_append(key, key_size, " beta1=%.17g beta2=%.17g", sc->beta1, sc->beta2);
  }
  return strlen(key) + 1 < key_size; /* a key that filled the buffer may have been cut */
}

static const char *const NAMES[3] = {"sigma_a", "sigma_s", "g"};

/* A stored file read line by line, for messages that name the line. */
typedef struct stored {
  FILE *f;
  char path[1200];
  int line_no;
  bool cut; /* the last line read ended without its newline */
  char line[EXPERIMENT_KEY_SIZE + 8];
  char *why;
  size_t why_size;
} stored_t;

/* The next line without its newline; false at the end, or for a line that
 * does not end in one (a file cut short, or longer than any we write). */
static bool next_line(stored_t *s) {
  ++s->line_no;
  s->cut = false;
  if (fgets(s->line, sizeof s->line, s->f) == NULL) return false;
  size_t n = strlen(s->line);
  s->cut = n == 0 || s->line[n - 1] != '\n';
  if (s->cut) return false;
  s->line[n - 1] = '\0';
  return true;
}

/* -1 after a message naming the file, the line and what it should hold. */
static int damaged(stored_t *s, const char *expected) {
  if (s->cut) {
    snprintf(s->why, s->why_size, "%s: line %d is cut short (\"%.120s\"), where %s belongs; the file is damaged "
             "(delete it to recompute)", s->path, s->line_no, s->line, expected);
  } else if (feof(s->f) || ferror(s->f)) {
    snprintf(s->why, s->why_size, "%s: ends after line %d, before %s; the file is damaged (delete it to recompute)",
             s->path, s->line_no - 1, expected);
  } else {
    snprintf(s->why, s->why_size, "%s: line %d: \"%.120s\" is not %s; the file is damaged (delete it to recompute)",
             s->path, s->line_no, s->line, expected);
  }
  fclose(s->f);
  return -1;
}

/* Opens <dir>/<file> and reads its first line "key,<key>": 1 if the key is
 * this one, 0 (file closed) if the file is missing or holds another cell's
 * settings, -1 with a message if it cannot be read. */
static int open_keyed(stored_t *s, const char *dir, const char *file, const char *key, char *why,
                      size_t why_size) {
  s->why = why;
  s->why_size = why_size;
  s->line_no = 0;
  snprintf(s->path, sizeof s->path, "%s/%s", dir, file);
  s->f = fopen(s->path, "r");
  if (s->f == NULL) {
    if (errno == ENOENT) return 0;
    snprintf(why, why_size, "%s: %s", s->path, strerror(errno));
    return -1;
  }
  bool same = next_line(s) && strncmp(s->line, "key,", 4) == 0 && strcmp(s->line + 4, key) == 0;
  if (!same) fclose(s->f);
  return same ? 1 : 0;
}

/* A stored figure: a number, finite and >= 0, or NaN where allowed (a
 * bound where the Fisher matrix was not positive definite). Advances *p. */
static bool stored_number(const char **p, bool nan_allowed, double *out) {
  char *end = NULL;
  double v = strtod(*p, &end);
  if (end == *p || !(isnan(v) ? nan_allowed : isfinite(v) && v >= 0.0)) return false;
  *out = v;
  *p = end;
  return true;
}

/* "<name>,<n>,<n>...": count figures after the name, and nothing after them. */
static bool stored_row(const char *line, const char *name, int count, bool nan_allowed, double *const out[]) {
  size_t len = strlen(name);
  if (strncmp(line, name, len) != 0) return false;
  const char *at = line + len;
  for (int i = 0; i < count; ++i) {
    if (*at++ != ',' || !stored_number(&at, nan_allowed, out[i])) return false;
  }
  return *at == '\0';
}

int experiment_cell_load(const char *dir, const char *key, experiment_cell_t *cell, char *why, size_t why_size) {
  stored_t s;
  int found = open_keyed(&s, dir, "cell.csv", key, why, why_size);
  if (found <= 0) return found;
  if (!next_line(&s) || strcmp(s.line, "param,mean,max") != 0) return damaged(&s, "\"param,mean,max\"");
  for (int p = 0; p < 3; ++p) {
    double *const figures[2] = {&cell->errors.mean[p], &cell->errors.max[p]};
    if (!next_line(&s) || !stored_row(s.line, NAMES[p], 2, false, figures)) {
      return damaged(&s, p == 0 ? "\"sigma_a,<mean>,<max>\" (finite numbers >= 0)"
                         : p == 1 ? "\"sigma_s,<mean>,<max>\" (finite numbers >= 0)"
                                  : "\"g,<mean>,<max>\" (finite numbers >= 0)");
    }
  }
  double *const seconds[1] = {&cell->seconds};
  if (!next_line(&s) || !stored_row(s.line, "seconds", 1, false, seconds)) {
    return damaged(&s, "\"seconds,<s>\" (a finite number >= 0)");
  }
  fclose(s.f);
  return 1;
}

int experiment_cell_store(const char *dir, const char *key, const experiment_cell_t *cell) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/cell.csv", dir);
  FILE *f = text_file_begin(path, tmp, sizeof tmp);
  if (f == NULL) return -1;
  fprintf(f, "key,%s\nparam,mean,max\n", key);
  /* %.17g: read back, the figures are the computed doubles, so a table of
   * stored cells prints what the run that computed them printed (%.9g,
   * rounded twice, moved a last printed digit). */
  for (int p = 0; p < 3; ++p) fprintf(f, "%s,%.17g,%.17g\n", NAMES[p], cell->errors.mean[p], cell->errors.max[p]);
  fprintf(f, "seconds,%.3f\n", cell->seconds);
  return text_file_commit(f, tmp, path);
}

int experiment_record_drop(const char *dir, const char *record, char *why, size_t why_size) {
  char path[1200];
  snprintf(path, sizeof path, "%s/%s", dir, record);
  if (remove(path) == 0 || errno == ENOENT) return 0;
  snprintf(why, why_size, "%s: %s (the record of an earlier run under other settings; remove it to go on)", path,
           strerror(errno));
  return -1;
}

/* What the data depend on: the truth, the imaging, the acquisition, the
 * loss's weights and mask and the seed; none of the optimizer's settings. */
static void data_key(const recon_scene_t *sc, char *key, size_t key_size) {
  snprintf(key, key_size,
           "data config=%d grid=%dx%dx%d size=%.17g eta=%.17g truth_seed=%llu noise_seed=%llu "
           "truth=%.17g:%.17g,%.17g:%.17g,%.17g:%.17g pixels_per_voxel=%d bin_width=%.17g truth_photons=%lld "
           "seed=%llu weighting=%d min_snr=%.17g",
           (int)sc->config, (int)sc->grid[0], (int)sc->grid[1], (int)sc->grid[2], sc->size, sc->eta,
           (unsigned long long)sc->truth_seed, (unsigned long long)sc->noise_model.seed, sc->truth_lo[0],
           sc->truth_hi[0], sc->truth_lo[1], sc->truth_hi[1], sc->truth_lo[2], sc->truth_hi[2],
           (int)sc->pixels_per_voxel, sc->bin_width, (long long)sc->truth_photons, (unsigned long long)sc->seed,
           sc->weighting, sc->min_snr);
  if (sc->independent_errors) {
    key_append(key, key_size, " independent_errors=1");
  }
  if (sc->pooled_errors) {
    key_append(key, key_size, " pooled_errors=1");
  }
  if (sc->expected_camera_errors) {
    key_append(key, key_size, " expected_camera_errors=1");
  }
}

/* The bound is computed at the truth from the data alone, so runs of the
 * optimizer with other settings share it. */
bool experiment_bound_key(const recon_scene_t *sc, int64_t photons, int32_t replicates, char *key,
                          size_t key_size) {
  char data[EXPERIMENT_KEY_SIZE];
  data_key(sc, data, sizeof data);
  int n = snprintf(key, key_size, "%s bound_photons=%lld replicates=%d", data, (long long)photons, (int)replicates);
  return strlen(data) + 1 < sizeof data && n >= 0 && (size_t)n + 1 < key_size;
}

int experiment_bound_load(const char *dir, const char *key, experiment_bound_t *b, char *why, size_t why_size) {
  stored_t s;
  int found = open_keyed(&s, dir, "bound.csv", key, why, why_size);
  if (found <= 0) return found;
  if (!next_line(&s) || strcmp(s.line, "param,mean,median,max,lower_mean,local_mean,local_max") != 0) {
    return damaged(&s, "\"param,mean,median,max,lower_mean,local_mean,local_max\"");
  }
  for (int p = 0; p < 3; ++p) {
    double *const figures[6] = {&b->mean[p],       &b->median[p],     &b->max[p],
                                &b->lower_mean[p], &b->local_mean[p], &b->local_max[p]};
    if (!next_line(&s) || !stored_row(s.line, NAMES[p], 6, true, figures)) {
      return damaged(&s, "a parameter's name and six figures (numbers >= 0 or nan)");
    }
  }
  double pd = 0.0, radius = 0.0;
  double *const pd_field[1] = {&pd}, *const seconds[1] = {&b->seconds};
  if (!next_line(&s) || !stored_row(s.line, "positive_definite", 1, false, pd_field) || (pd != 0.0 && pd != 1.0)) {
    return damaged(&s, "\"positive_definite,<0 or 1>\"");
  }
  /* -1 where no local bound stands in (stored_number refuses signs). */
  bool read = next_line(&s), none = read && strcmp(s.line, "local_radius,-1") == 0;
  double *const radius_field[1] = {&radius};
  if (!read || (!none && (!stored_row(s.line, "local_radius", 1, false, radius_field) ||
                          radius >= RECON_LOCAL_RADII || radius != floor(radius)))) {
    return damaged(&s, "\"local_radius,<-1 to 3>\"");
  }
  if (!next_line(&s) || !stored_row(s.line, "seconds", 1, false, seconds)) {
    return damaged(&s, "\"seconds,<s>\" (a finite number >= 0)");
  }
  b->positive_definite = (int32_t)pd;
  b->local_radius = none ? -1 : (int32_t)radius;
  fclose(s.f);
  return 1;
}

int experiment_bound_store(const char *dir, const char *key, const experiment_bound_t *b) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/bound.csv", dir);
  FILE *f = text_file_begin(path, tmp, sizeof tmp);
  if (f == NULL) return -1;
  fprintf(f, "key,%s\nparam,mean,median,max,lower_mean,local_mean,local_max\n", key);
  for (int p = 0; p < 3; ++p) { /* %.17g: as experiment_cell_store */
    fprintf(f, "%s,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", NAMES[p], b->mean[p], b->median[p], b->max[p],
            b->lower_mean[p], b->local_mean[p], b->local_max[p]);
  }
  fprintf(f, "positive_definite,%d\nlocal_radius,%d\nseconds,%.3f\n", (int)b->positive_definite,
          (int)b->local_radius, b->seconds);
  return text_file_commit(f, tmp, path);
}

/* from/name into dir/name, written whole and renamed (text_file_begin:
 * the bytes of any file). A missing source is no error: a bound's maps
 * are optional. -1 with a message in why naming the file that failed, the
 * source or the copy, and the reason (errno's, not a generic one: a full
 * disk or a file size limit is what the user needs to know). */
static int copy_into(const char *dir, const char *from, const char *name, char *why, size_t why_size) {
  char src[1200], dst[1200], tmp[1220];
  snprintf(src, sizeof src, "%s/%s", from, name);
  snprintf(dst, sizeof dst, "%s/%s", dir, name);
  FILE *in = fopen(src, "rb");
  if (in == NULL && errno == ENOENT) return 0;
  if (in == NULL) {
    snprintf(why, why_size, "%s: %s", src, strerror(errno));
    return -1;
  }
  FILE *out = text_file_begin(dst, tmp, sizeof tmp);
  if (out == NULL) {
    snprintf(why, why_size, "%s: %s (copying %s)", dst, strerror(errno), src);
    fclose(in);
    return -1;
  }
  char buf[65536];
  size_t n;
  bool wrote = true;
  errno = 0;
  while (wrote && (n = fread(buf, 1, sizeof buf, in)) > 0) wrote = fwrite(buf, 1, n, out) == n;
  int err = errno;
  bool read = !ferror(in);
  fclose(in);
  if (!wrote || !read) {
    fclose(out);
    remove(tmp);
    snprintf(why, why_size, "%s: %s (copying %s)", read ? dst : src, strerror(err != 0 ? err : EIO), src);
    return -1;
  }
  if (text_file_commit(out, tmp, dst) != 0) {
    snprintf(why, why_size, "%s: %s (copying %s)", dst, strerror(errno), src);
    return -1;
  }
  return 0;
}

int experiment_bound_adopt(const char *dir, const char *from, const char *key, experiment_bound_t *b, char *why,
                           size_t why_size) {
  int found = experiment_bound_load(from, key, b, why, why_size);
  if (found <= 0) return found;
  static const char *const MAPS[] = {"bound.exr", "bound_sigma_a.png", "bound_sigma_s.png", "bound_g.png"};
  for (size_t i = 0; i < sizeof MAPS / sizeof MAPS[0]; ++i) {
    if (copy_into(dir, from, MAPS[i], why, why_size) != 0) return -1;
  }
  /* bound.csv last: once it is there, the maps it describes are too. */
  if (experiment_bound_store(dir, key, b) != 0) {
    snprintf(why, why_size, "%s/bound.csv: %s", dir, strerror(errno));
    return -1;
  }
  return 1;
}
