/* Finished experiment cells as small CSV files (cells.h). */
#include "cells.h"

#include <errno.h>
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

void experiment_cell_key(const recon_scene_t *sc, char *key, size_t key_size) {
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
}

static const char *const NAMES[3] = {"sigma_a", "sigma_s", "g"};

/* <dir>/<file> open after its first line "key,<key>"; NULL if it is
 * missing or was stored for other settings. */
static FILE *open_keyed(const char *dir, const char *file, const char *key) {
  char path[1200], line[2048];
  snprintf(path, sizeof path, "%s/%s", dir, file);
  FILE *f = fopen(path, "r");
  if (f == NULL) return NULL;
  bool ok = fgets(line, sizeof line, f) != NULL && strncmp(line, "key,", 4) == 0;
  if (ok) {
    line[strcspn(line, "\n")] = '\0';
    ok = strcmp(line + 4, key) == 0;
  }
  if (!ok) {
    fclose(f);
    return NULL;
  }
  return f;
}

bool experiment_cell_load(const char *dir, const char *key, experiment_cell_t *cell) {
  char line[2048];
  FILE *f = open_keyed(dir, "cell.csv", key);
  if (f == NULL) return false;
  bool ok = fgets(line, sizeof line, f) != NULL && strcmp(line, "param,mean,max\n") == 0;
  for (int p = 0; ok && p < 3; ++p) {
    char name[16];
    ok = fgets(line, sizeof line, f) != NULL &&
         sscanf(line, "%15[a-z_],%lf,%lf", name, &cell->errors.mean[p], &cell->errors.max[p]) == 3 &&
         strcmp(name, NAMES[p]) == 0;
  }
  ok = ok && fgets(line, sizeof line, f) != NULL && sscanf(line, "seconds,%lf", &cell->seconds) == 1;
  fclose(f);
  return ok;
}

int experiment_cell_store(const char *dir, const char *key, const experiment_cell_t *cell) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/cell.csv", dir);
  FILE *f = recon_text_begin(path, tmp, sizeof tmp);
  if (f == NULL) return -1;
  fprintf(f, "key,%s\nparam,mean,max\n", key);
  for (int p = 0; p < 3; ++p) fprintf(f, "%s,%.9g,%.9g\n", NAMES[p], cell->errors.mean[p], cell->errors.max[p]);
  fprintf(f, "seconds,%.3f\n", cell->seconds);
  return recon_text_commit(f, tmp, path);
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
void experiment_bound_key(const recon_scene_t *sc, int64_t photons, int32_t replicates, char *key,
                          size_t key_size) {
  char data[1024];
  data_key(sc, data, sizeof data);
  snprintf(key, key_size, "%s bound_photons=%lld replicates=%d", data, (long long)photons, (int)replicates);
}

/* A number as bound.csv writes it: NaN where the Fisher matrix was not
 * positive definite. */
static bool parse_number(const char **p, double *out) {
  char *end = NULL;
  *out = strtod(*p, &end);
  if (end == *p) return false;
  *p = end;
  return true;
}

bool experiment_bound_load(const char *dir, const char *key, experiment_bound_t *b) {
  char line[2048];
  FILE *f = open_keyed(dir, "bound.csv", key);
  if (f == NULL) return false;
  bool ok = fgets(line, sizeof line, f) != NULL && strcmp(line, "param,mean,median,max,lower_mean,local_mean,local_max\n") == 0;
  for (int p = 0; ok && p < 3; ++p) {
    size_t len = strlen(NAMES[p]);
    ok = fgets(line, sizeof line, f) != NULL && strncmp(line, NAMES[p], len) == 0 && line[len] == ',';
    const char *at = line + len;
    double *field[6] = {&b->mean[p],       &b->median[p],     &b->max[p],
                        &b->lower_mean[p], &b->local_mean[p], &b->local_max[p]};
    for (int i = 0; ok && i < 6; ++i) ok = *at++ == ',' && parse_number(&at, field[i]);
  }
  int pd = 0, radius = -1;
  ok = ok && fgets(line, sizeof line, f) != NULL && sscanf(line, "positive_definite,%d", &pd) == 1;
  ok = ok && fgets(line, sizeof line, f) != NULL && sscanf(line, "local_radius,%d", &radius) == 1;
  b->positive_definite = pd;
  b->local_radius = radius;
  ok = ok && fgets(line, sizeof line, f) != NULL && sscanf(line, "seconds,%lf", &b->seconds) == 1;
  fclose(f);
  return ok;
}

int experiment_bound_store(const char *dir, const char *key, const experiment_bound_t *b) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/bound.csv", dir);
  FILE *f = recon_text_begin(path, tmp, sizeof tmp);
  if (f == NULL) return -1;
  fprintf(f, "key,%s\nparam,mean,median,max,lower_mean,local_mean,local_max\n", key);
  for (int p = 0; p < 3; ++p) {
    fprintf(f, "%s,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", NAMES[p], b->mean[p], b->median[p], b->max[p],
            b->lower_mean[p], b->local_mean[p], b->local_max[p]);
  }
  fprintf(f, "positive_definite,%d\nlocal_radius,%d\nseconds,%.3f\n", (int)b->positive_definite,
          (int)b->local_radius, b->seconds);
  return recon_text_commit(f, tmp, path);
}

/* from/name into dir/name, written whole and renamed (recon_text_begin:
 * the bytes of any file). A missing source is no error: a bound's maps
 * are optional. */
static int copy_into(const char *dir, const char *from, const char *name) {
  char src[1200], dst[1200], tmp[1220];
  snprintf(src, sizeof src, "%s/%s", from, name);
  snprintf(dst, sizeof dst, "%s/%s", dir, name);
  FILE *in = fopen(src, "rb");
  if (in == NULL) return errno == ENOENT ? 0 : -1;
  FILE *out = recon_text_begin(dst, tmp, sizeof tmp);
  if (out == NULL) {
    fclose(in);
    return -1;
  }
  char buf[65536];
  size_t n;
  bool ok = true;
  while (ok && (n = fread(buf, 1, sizeof buf, in)) > 0) ok = fwrite(buf, 1, n, out) == n;
  ok = ok && !ferror(in);
  fclose(in);
  if (!ok) {
    fclose(out);
    remove(tmp);
    errno = EIO;
    return -1;
  }
  return recon_text_commit(out, tmp, dst);
}

int experiment_bound_adopt(const char *dir, const char *from, const char *key, experiment_bound_t *b) {
  if (!experiment_bound_load(from, key, b)) return 0;
  static const char *const MAPS[] = {"bound.exr", "bound_sigma_a.png", "bound_sigma_s.png", "bound_g.png"};
  for (size_t i = 0; i < sizeof MAPS / sizeof MAPS[0]; ++i) {
    if (copy_into(dir, from, MAPS[i]) != 0) return -1;
  }
  /* bound.csv last: once it is there, the maps it describes are too. */
  return experiment_bound_store(dir, key, b) == 0 ? 1 : -1;
}
