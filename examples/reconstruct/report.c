/* Errors of a recovery and the files that show it. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "recon.h"

void recon_errors(const hetinv_medium_t *truth, const hetinv_medium_t *rec, recon_errors_t *e) {
  size_t n = hetinv_medium_voxel_count(truth);
  for (int p = 0; p < 3; ++p) {
    const double *a = hetinv_medium_grid(truth, p), *b = hetinv_medium_grid(rec, p);
    double sum = 0.0, mx = 0.0;
    for (size_t i = 0; i < n; ++i) {
      double rel = fabs(b[i] - a[i]) / fabs(a[i]);
      sum += rel;
      mx = fmax(mx, rel);
    }
    e->mean[p] = sum / (double)n;
    e->max[p] = mx;
  }
  e->has_bound = false;
}

/* Value of parameter p at section pixel (x, z): the middle y slice. */
static double section_value(const hetinv_medium_t *m, int p, int32_t x, int32_t z) {
  int32_t d[3];
  hetinv_medium_get_dims(m, d);
  const double *g = hetinv_medium_grid(m, p);
  return g[((size_t)z * (size_t)d[1] + (size_t)(d[1] / 2)) * (size_t)d[0] + (size_t)x];
}

/* truth | recovery, side by side with a one-cell gap, each cell `s` pixels
 * (without a truth, the recovery alone). */
static hetinv_result_t write_png(hetinv_context_t *ctx, const char *dir, int p, const hetinv_medium_t *truth,
                                 const hetinv_medium_t *rec) {
  int32_t d[3];
  hetinv_medium_get_dims(rec, d);
  const int32_t left = truth ? d[0] + 1 : 0; /* cells before the recovery */
  if (truth == NULL) truth = rec;
  int32_t s = 256 / d[0] > 1 ? 256 / d[0] : 1, w = (left + d[0]) * s, h = d[2] * s;
  double lo = (double)INFINITY, hi = -(double)INFINITY;
  for (int32_t z = 0; z < d[2]; ++z) {
    for (int32_t x = 0; x < d[0]; ++x) {
      double a = section_value(truth, p, x, z), b = section_value(rec, p, x, z);
      lo = fmin(lo, fmin(a, b));
      hi = fmax(hi, fmax(a, b));
    }
  }
  hetinv_image_t *img = NULL;
  hetinv_result_t r = hetinv_image_create(ctx, w, h, 1, &img);
  if (r != HETINV_SUCCESS) return r;
  float *px = hetinv_image_channel_data(img, 0);
  for (int32_t y = 0; y < h; ++y) {
    for (int32_t x = 0; x < w; ++x) {
      int32_t cx = x / s, cz = d[2] - 1 - y / s; /* z up */
      double v = cx >= left ? section_value(rec, p, cx - left, cz)
               : cx < d[0] ? section_value(truth, p, cx, cz) : lo;
      px[(size_t)y * (size_t)w + (size_t)x] = (float)v;
    }
  }
  char path[1200];
  snprintf(path, sizeof path, "%s/maps_%s.png", dir, hetinv_param_name(p));
  r = hetinv_image_write_png(img, 0, path, lo, hi > lo ? hi : lo + 1.0, HETINV_COLORMAP_VIRIDIS);
  hetinv_image_destroy(&img);
  return r;
}

static hetinv_result_t write_exr(hetinv_context_t *ctx, const char *dir, const hetinv_medium_t *truth,
                                 const hetinv_medium_t *rec) {
  int32_t d[3];
  hetinv_medium_get_dims(rec, d);
  const int kinds = truth ? 2 : 1; /* truth_<p> and recovered_<p>, or recovered_<p> alone */
  hetinv_image_t *img = NULL;
  hetinv_result_t r = hetinv_image_create(ctx, d[0], d[2], 3 * kinds, &img);
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    char name[64];
    for (int which = 2 - kinds; r == HETINV_SUCCESS && which < 2; ++which) {
      snprintf(name, sizeof name, "%s_%s", which ? "recovered" : "truth", hetinv_param_name(p));
      int32_t c = kinds * p + which - (2 - kinds);
      r = hetinv_image_set_channel_name(img, c, name);
      float *px = hetinv_image_channel_data(img, c);
      for (int32_t z = 0; z < d[2]; ++z) {
        for (int32_t x = 0; x < d[0]; ++x) {
          px[(size_t)z * (size_t)d[0] + (size_t)x] = (float)section_value(which ? rec : truth, p, x, z);
        }
      }
    }
  }
  if (r == HETINV_SUCCESS) r = hetinv_image_set_attribute_string(img, "hetinv:content", "x-z section at the middle of y; row = z");
  char path[1200];
  snprintf(path, sizeof path, "%s/maps.exr", dir);
  if (r == HETINV_SUCCESS) r = hetinv_image_write_exr(img, path);
  hetinv_image_destroy(&img);
  return r;
}

hetinv_result_t recon_write_outputs(hetinv_context_t *ctx, const recon_scene_t *sc, const hetinv_medium_t *truth,
                                    const hetinv_medium_t *rec, const recon_errors_t *e, char *msg, size_t msg_size) {
  const char *dir = sc->output;
  hetinv_result_t r = HETINV_SUCCESS;
  char path[1200];
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    snprintf(path, sizeof path, "%s/recovered_%s.vol", dir, hetinv_param_name(p));
    r = hetinv_medium_write_vol(rec, p, path);
    if (r == HETINV_SUCCESS && truth != NULL) {
      snprintf(path, sizeof path, "%s/truth_%s.vol", dir, hetinv_param_name(p));
      r = hetinv_medium_write_vol(truth, p, path);
    }
    if (r == HETINV_SUCCESS) {
      snprintf(path, sizeof path, "%s/maps_%s.png", dir, hetinv_param_name(p));
      r = write_png(ctx, dir, p, truth, rec);
    }
  }
  if (r == HETINV_SUCCESS) {
    snprintf(path, sizeof path, "%s/maps.exr", dir);
    r = write_exr(ctx, dir, truth, rec);
  }
  if (r != HETINV_SUCCESS) {
    snprintf(msg, msg_size, "%s: %s", path, hetinv_context_last_error_message(ctx));
    return r;
  }
  if (truth == NULL) return HETINV_SUCCESS; /* nothing to compare with */
  snprintf(path, sizeof path, "%s/errors.csv", dir);
  char tmp[1220];
  FILE *f = text_file_begin(path, tmp, sizeof tmp);
  if (f != NULL) {
    fprintf(f, "parameter,mean_relative_error,max_relative_error%s\n",
            e->has_bound ? ",mean_relative_bound,achieved_over_bound,max_voxel_error_over_bound,"
                           "voxels_over_2x_bound,voxels_bounded" : "");
    for (int p = 0; p < 3; ++p) {
      fprintf(f, "%s,%.6f,%.6f", hetinv_param_name(p), e->mean[p], e->max[p]);
      if (e->has_bound) {
        fprintf(f, ",%.6g,%.6g,%.6g,%zu,%zu", e->bound_mean[p], e->achieved_over_bound[p], e->max_over_bound[p],
                e->over_2x_bound[p], e->bounded[p]);
      }
      fprintf(f, "\n");
    }
  }
  if (f == NULL || text_file_commit(f, tmp, path) != 0) {
    snprintf(msg, msg_size, "%s: %s", path, strerror(errno));
    return HETINV_ERROR_IO;
  }
  return HETINV_SUCCESS;
}

hetinv_result_t recon_read_recovery(hetinv_context_t *ctx, const recon_scene_t *sc, hetinv_medium_t **out, char *msg,
                                    size_t msg_size) {
  hetinv_result_t r = recon_medium_create(ctx, sc, out);
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    char path[1200];
    snprintf(path, sizeof path, "%s/recovered_%s.vol", sc->output, hetinv_param_name(p));
    r = hetinv_medium_read_vol(*out, p, path);
    if (r != HETINV_SUCCESS) snprintf(msg, msg_size, "%s: %s", path, hetinv_context_last_error_message(ctx));
  }
  if (r == HETINV_SUCCESS) r = hetinv_medium_commit(*out);
  if (r != HETINV_SUCCESS) hetinv_medium_destroy(out);
  return r;
}

void recon_print_in_loss(const char *prog, const recon_scene_t *sc, const recon_imaging_t *im) {
  size_t n = hetinv_measurements_value_count(im->set), kept = 0;
  const uint8_t *mask = hetinv_measurements_mask(im->set);
  for (size_t i = 0; i < n; ++i) kept += mask[i] != 0;
  printf("%s: %zu of %zu values in the loss (acquisition.min_snr %g leaves out values whose %s "
         "standard error exceeds value/%g)\n", prog, kept, n, sc->min_snr,
         sc->min_snr_errors == RECON_SNR_RESIDUAL ? "residual's" : "data's", sc->min_snr);
  fflush(stdout);
}
