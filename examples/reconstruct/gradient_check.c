/* The data-or-optimizer test by the gradient (gradient_check.h). */
#include "gradient_check.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "stored_cell.h"

/* Streams no optimizer iteration, acquisition or fit check uses; a loss
 * gradient takes two (its render and its gradient pass). */
#define GRADIENT_CHECK_STREAM 61000

/* Mean, standard error and spread of `replicates` gradients at `medium`. */
static hetinv_result_t replicate(hetinv_estimator_t *est, const hetinv_medium_t *medium,
                                 const hetinv_measurements_t *set, const hetinv_param_map_t *map, int32_t replicates,
                                 double *g, size_t k, gradient_stats_t *out) {
  hetinv_result_t r = HETINV_SUCCESS;
  for (size_t i = 0; i < k; ++i) out->mean[i] = out->sd[i] = 0.0;
  for (int32_t j = 0; r == HETINV_SUCCESS && j < replicates; ++j) {
    double loss = 0.0;
    r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, GRADIENT_CHECK_STREAM + 2 * j);
    if (r == HETINV_SUCCESS) r = hetinv_estimator_loss_gradient(est, medium, set, map, &loss, NULL, g, k);
    /* Welford's running mean and sum of squared deviations (in sd). */
    for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) {
      double d = g[i] - out->mean[i];
      out->mean[i] += d / (j + 1);
      out->sd[i] += d * (g[i] - out->mean[i]);
    }
  }
  for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) {
    out->sd[i] = sqrt(out->sd[i] / (replicates - 1));
    out->se[i] = out->sd[i] / sqrt((double)replicates);
  }
  return r;
}

/* dᵀF d (gradient_check.h) from `pairs` pairs of Jacobian–vector products
 * at the truth, each pair on two streams of its own. */
static hetinv_result_t separation(hetinv_estimator_t *est, const hetinv_medium_t *truth, const hetinv_medium_t *rec,
                                  const hetinv_measurements_t *set, const hetinv_param_map_t *map, int32_t pairs,
                                  size_t k, gradient_check_t *out) {
  size_t n = hetinv_measurements_value_count(set);
  double *d = malloc((2 * k + 2 * n + 1) * sizeof *d);
  hetinv_result_t r = d ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  double *t = d + k, *ja = d + 2 * k, *jb = d + 2 * k + n;
  if (r == HETINV_SUCCESS) r = hetinv_param_map_extract(map, rec, d, k);
  if (r == HETINV_SUCCESS) r = hetinv_param_map_extract(map, truth, t, k);
  for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) d[i] -= t[i];
  const double *w = hetinv_measurements_weights(set);
  const uint8_t *mask = hetinv_measurements_mask(set);
  double sum = 0.0, sq = 0.0;
  for (int32_t j = 0; r == HETINV_SUCCESS && j < pairs; ++j) {
    r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, GRADIENT_CHECK_STREAM + 2 * (pairs + j));
    if (r == HETINV_SUCCESS) r = hetinv_estimator_jvp(est, truth, set, map, d, k, ja, NULL, n);
    if (r == HETINV_SUCCESS) {
      r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, GRADIENT_CHECK_STREAM + 2 * (pairs + j) + 1);
    }
    if (r == HETINV_SUCCESS) r = hetinv_estimator_jvp(est, truth, set, map, d, k, jb, NULL, n);
    double s = 0.0;
    for (size_t i = 0; r == HETINV_SUCCESS && i < n; ++i) {
      if (mask[i] && w[i] > 0.0) s += w[i] * ja[i] * jb[i];
    }
    sum += s;
    sq += s * s;
  }
  if (r == HETINV_SUCCESS) {
    double m = sum / pairs;
    out->separation2 = m;
    out->separation2_se = sqrt(fmax(sq / pairs - m * m, 0.0) / (pairs - 1.0));
  }
  free(d);
  return r;
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void summarise(const gradient_check_t *gc, const hetinv_medium_t *truth, const hetinv_medium_t *rec,
                      size_t voxels, double threshold, gradient_summary_t *s) {
  *s = (gradient_summary_t){.entries = voxels, .threshold = threshold};
  double *snr = malloc((voxels ? voxels : 1) * sizeof *snr);
  for (int p = 0; p < 3; ++p) {
    const double *t = hetinv_medium_grid(truth, p), *x = hetinv_medium_grid(rec, p);
    size_t pulled = 0;
    for (size_t v = 0; v < voxels; ++v) {
      size_t i = (size_t)p * voxels + v;
      if (fabs(gc->truth.mean[i]) > 3.0 * gc->truth.se[i]) ++s->truth_beyond3[p];
      if (!(fabs(x[v] - t[v]) > threshold * fabs(t[v]))) continue;
      ++s->missed[p];
      /* Descent moves against the gradient: back to the truth when the
       * gradient has the sign of (recovery − truth). */
      double toward = gc->recovery.mean[i] * (x[v] - t[v]) > 0.0 ? 1.0 : -1.0;
      if (!(fabs(gc->recovery.mean[i]) > 3.0 * gc->recovery.se[i])) {
        ++s->flat[p];
      } else if (toward > 0.0) {
        ++s->pulled[p];
        if (snr) snr[pulled++] = fabs(gc->recovery.mean[i]) / gc->recovery.sd[i];
      } else {
        ++s->pushed[p];
      }
    }
    s->pulled_snr_median[p] = NAN;
    if (snr && pulled) {
      qsort(snr, pulled, sizeof *snr, compare_double);
      s->pulled_snr_median[p] = pulled % 2 ? snr[pulled / 2] : 0.5 * (snr[pulled / 2 - 1] + snr[pulled / 2]);
    }
  }
  free(snr);
}

/* gradient_check.exr, on the x-z section at the middle of y (row = z),
 * per parameter: z = mean ÷ standard error at the recovery and at the
 * truth, SNR = mean ÷ spread at the recovery, and the mean and spread at
 * the recovery per unit of ln π (π times the gradient: the loss's change
 * for a relative change, comparable with the bound's 1/b² curvature). */
static hetinv_result_t write_maps(hetinv_context_t *ctx, const recon_scene_t *sc, const hetinv_medium_t *truth,
                                  const hetinv_medium_t *rec, const gradient_check_t *gc, char *msg,
                                  size_t msg_size) {
  enum { KINDS = 5 };
  int32_t d[3];
  hetinv_medium_get_dims(truth, d);
  size_t voxels = (size_t)d[0] * (size_t)d[1] * (size_t)d[2];
  hetinv_image_t *img = NULL;
  hetinv_result_t r = hetinv_image_create(ctx, d[0], d[2], 3 * KINDS, &img);
  static const char *const kinds[KINDS] = {"z_recovery", "snr_recovery", "z_truth", "dlog_recovery", "dlog_sd_recovery"};
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    const double *x = hetinv_medium_grid(rec, p);
    for (int kind = 0; r == HETINV_SUCCESS && kind < KINDS; ++kind) {
      const gradient_stats_t *st = kind == 2 ? &gc->truth : &gc->recovery;
      char name[64];
      snprintf(name, sizeof name, "%s_%s", kinds[kind], hetinv_param_name(p));
      r = hetinv_image_set_channel_name(img, KINDS * p + kind, name);
      float *px = hetinv_image_channel_data(img, KINDS * p + kind);
      for (int32_t z = 0; r == HETINV_SUCCESS && z < d[2]; ++z) {
        for (int32_t ix = 0; ix < d[0]; ++ix) {
          size_t v = ((size_t)z * (size_t)d[1] + (size_t)(d[1] / 2)) * (size_t)d[0] + (size_t)ix;
          size_t i = (size_t)p * voxels + v;
          double value = kind == 3 ? x[v] * st->mean[i] : kind == 4 ? x[v] * st->sd[i] : 0.0;
          if (kind < 3) {
            const double den = kind == 1 ? st->sd[i] : st->se[i];
            value = den > 0.0 ? st->mean[i] / den : 0.0;
          }
          px[(size_t)z * (size_t)d[0] + (size_t)ix] = (float)value;
        }
      }
    }
  }
  if (r == HETINV_SUCCESS) {
    r = hetinv_image_set_attribute_string(img, "hetinv:content",
                                          "the run's loss gradient over independent replicates (every source, the "
                                          "run's photons, clip and gain mode; no smoothness prior): z = mean / "
                                          "standard error at the recovery and at the truth, snr = mean / one "
                                          "replicate's standard deviation at the recovery, and at the recovery "
                                          "the mean and that deviation per unit of ln(value) (value times the "
                                          "gradient); x-z section at the middle of y; row = z");
  }
  char path[1200];
  snprintf(path, sizeof path, "%s/gradient_check.exr", sc->output);
  if (r == HETINV_SUCCESS) r = hetinv_image_write_exr(img, path);
  if (r != HETINV_SUCCESS) snprintf(msg, msg_size, "%s: %s", path, hetinv_context_last_error_message(ctx));
  hetinv_image_destroy(&img);
  return r;
}

/* An efficient unbiased recovery of k entries lies at dᵀF d ~ χ²_k,
 * k ± √(2k); beyond k + 2√(2k) the data put the truth further from the
 * recovery than their noise explains. */
static const char *separation_verdict(const gradient_check_t *gc) {
  double d2 = gc->separation2, se = gc->separation2_se, k = 3.0 * (double)gc->summary.entries;
  double top = k + 2.0 * sqrt(2.0 * k);
  return d2 - 2.0 * se > top ? "apart" : d2 + 2.0 * se < top ? "within" : "undecided";
}

static int store(const recon_scene_t *sc, const gradient_check_t *gc) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/gradient_check.csv", sc->output);
  FILE *out = text_file_begin(path, tmp, sizeof tmp);
  if (out == NULL) return -1;
  const gradient_summary_t *s = &gc->summary;
  fprintf(out, "param,truth_beyond_3_se,entries,missed,pulled,flat,pushed,pulled_snr_median\n");
  for (int p = 0; p < 3; ++p) {
    fprintf(out, "%s,%zu,%zu,%zu,%zu,%zu,%zu,%.4g\n", hetinv_param_name(p), s->truth_beyond3[p], s->entries,
            s->missed[p], s->pulled[p], s->flat[p], s->pushed[p], s->pulled_snr_median[p]);
  }
  double k = 3.0 * (double)s->entries;
  fprintf(out, "separation,%.9g,%.3g,%.0f,%.4g,%s\n", gc->separation2, gc->separation2_se, k,
          k + 2.0 * sqrt(2.0 * k), separation_verdict(gc));
  fprintf(out, "threshold,%.4g\nreplicates,%d\nphotons,%lld\nseconds,%.3f\n", s->threshold, (int)gc->replicates,
          (long long)gc->photons, gc->seconds);
  return text_file_commit(out, tmp, path);
}

hetinv_result_t gradient_check_compare(hetinv_context_t *ctx, const recon_scene_t *sc,
                                       const hetinv_measurements_t *set, const hetinv_medium_t *truth,
                                       const hetinv_medium_t *rec, int32_t replicates, double threshold,
                                       gradient_check_t *out, char *msg, size_t msg_size) {
  *out = (gradient_check_t){.replicates = replicates, .photons = sc->photons};
  msg[0] = '\0';
  double t0 = recon_now();
  hetinv_param_map_t *map = NULL;
  hetinv_estimator_t *est = NULL;
  hetinv_result_t r = hetinv_param_map_create_identity(truth, HETINV_FREE_ALL, &map);
  size_t k = map ? hetinv_param_map_size(map) : 0;
  if (r == HETINV_SUCCESS) {
    out->buffer = malloc(7 * k * sizeof *out->buffer);
    if (out->buffer == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  double *g = NULL;
  if (r == HETINV_SUCCESS) {
    double *b = out->buffer;
    out->truth = (gradient_stats_t){b, b + k, b + 2 * k};
    out->recovery = (gradient_stats_t){b + 3 * k, b + 4 * k, b + 5 * k};
    g = b + 6 * k;
    r = hetinv_estimator_create(ctx, &est);
  }
  if (r == HETINV_SUCCESS) r = recon_estimator_configure(est, sc);
  if (r == HETINV_SUCCESS) r = replicate(est, truth, set, map, replicates, g, k, &out->truth);
  if (r == HETINV_SUCCESS) r = replicate(est, rec, set, map, replicates, g, k, &out->recovery);
  if (r == HETINV_SUCCESS) r = separation(est, truth, rec, set, map, replicates, k, out);
  if (r == HETINV_SUCCESS) summarise(out, truth, rec, k / 3, threshold, &out->summary);
  if (r == HETINV_SUCCESS) r = write_maps(ctx, sc, truth, rec, out, msg, msg_size);
  else snprintf(msg, msg_size, "%s: %s", sc->name, hetinv_context_last_error_message(ctx));
  out->seconds = recon_now() - t0;
  if (r == HETINV_SUCCESS && store(sc, out) != 0) {
    snprintf(msg, msg_size, "%s/gradient_check.csv: %s", sc->output, strerror(errno));
    r = HETINV_ERROR_IO;
  }
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  if (r != HETINV_SUCCESS) gradient_check_release(out);
  return r;
}

int gradient_check_run(const recon_scene_t *sc, int64_t threads, int32_t replicates, double threshold,
                       gradient_check_t *out, char *msg, size_t msg_size) {
  *out = (gradient_check_t){0};
  double t0 = recon_now();
  stored_cell_t cell;
  if (stored_cell_open(sc, threads, &cell, msg, msg_size) != 0) return -1;
  hetinv_result_t r = gradient_check_compare(cell.ctx, sc, cell.im.set, cell.truth, cell.recovery, replicates,
                                             threshold, out, msg, msg_size);
  out->seconds = recon_now() - t0; /* the data's simulation included */
  stored_cell_close(&cell);
  return r == HETINV_SUCCESS ? 0 : -1;
}

void gradient_check_print(const recon_scene_t *sc, const gradient_check_t *gc) {
  const gradient_summary_t *s = &gc->summary;
  printf("%s: gradient check (%d replicates of every source at %lld photons, %.0f s; no smoothness prior):\n",
         sc->name, (int)gc->replicates, (long long)gc->photons, gc->seconds);
  for (int p = 0; p < 3; ++p) {
    printf("  %-7s at the truth %zu of %zu entries beyond 3 standard errors; of %zu voxels off by more than %.0f %%, "
           "%zu pulled back (median SNR per render %.3g), %zu flat, %zu pushed away\n",
           hetinv_param_name(p), s->truth_beyond3[p], s->entries, s->missed[p], 100.0 * s->threshold, s->pulled[p],
           s->pulled_snr_median[p], s->flat[p], s->pushed[p]);
  }
  double d2 = gc->separation2, se = gc->separation2_se, k = 3.0 * (double)s->entries;
  const char *v = separation_verdict(gc);
  printf("  the data separate the truth and the recovery by d'Fd = %.4g +- %.2g (linearised at the truth; %d pairs "
         "of Jacobian-vector products; an efficient unbiased recovery of %.0f entries: %.0f +- %.0f): %s\n",
         d2, se, (int)gc->replicates, k, k, sqrt(2.0 * k),
         v[0] == 'a'   ? "further apart than the data's noise explains: the data tell them apart"
         : v[0] == 'w' ? "within the data's noise: the data do not tell them apart"
                       : "undecided at this precision");
  printf("  wrote %s/gradient_check.{exr,csv}\n", sc->output);
  fflush(stdout);
}

void gradient_check_release(gradient_check_t *gc) {
  free(gc->buffer);
  gc->buffer = NULL;
  gc->truth = gc->recovery = (gradient_stats_t){0};
}
