/* Per-voxel misses of a cell, each set against its Cramér–Rao bound. */
#include "verdict.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <hetinv/hetinv.h>

float *experiment_vol_load(hetinv_context_t *ctx, const char *path, int32_t d[3], char *msg, size_t n) {
  hetinv_vol_header_t h;
  float *x = NULL;
  if (hetinv_vol_read_header(ctx, path, &h) == HETINV_SUCCESS) {
    size_t count = (size_t)h.dims[0] * (size_t)h.dims[1] * (size_t)h.dims[2];
    if (h.channels != 1) {
      snprintf(msg, n, "%s: %d channels, expected 1", path, (int)h.channels);
      return NULL;
    }
    x = malloc(count * sizeof *x);
    if (x == NULL) {
      snprintf(msg, n, "%s: out of memory for %zu voxels", path, count);
      return NULL;
    }
    if (hetinv_vol_read(ctx, path, &h, x, count) == HETINV_SUCCESS) {
      for (int a = 0; a < 3; ++a) d[a] = h.dims[a];
      return x;
    }
  }
  snprintf(msg, n, "%s: %s", path, hetinv_context_last_error_message(ctx));
  free(x);
  return NULL;
}

double experiment_normal_tail2(double t) { return erfc(fabs(t) / sqrt(2.0)); }

double experiment_expected_max_abs_normal(size_t n) {
  /* E[max] = ∫ P(max > t) dt over t >= 0, P(max > t) = 1 - (1 - tail(t))^n;
   * the integrand is below 1e-16 past t = 12 for any n a grid has. */
  const double dt = 1e-3;
  double sum = 0.0;
  for (double t = 0.5 * dt; t < 12.0; t += dt) {
    double tail = experiment_normal_tail2(t);
    sum += -expm1((double)n * log1p(-tail)) * dt;
  }
  return sum;
}

/* The rule's allowance for a voxel whose relative bound is `bound`. */
static double allowance(double bound, double max_error) {
  return bound > max_error ? VERDICT_BOUND_FACTOR * bound : max_error;
}

void experiment_verdict_voxel(experiment_verdict_t *v, int p, double truth, double recovered, double bound,
                              double max_error) {
  if (!(bound > 0.0) || !isfinite(bound) || truth == 0.0) return;
  double err = fabs(recovered - truth) / fabs(truth);
  ++v->voxels[p];
  v->over[p] += err > max_error;
  /* The allowance grows with the bound only where the bound exceeds the target. */
  double allowed = allowance(bound, max_error);
  v->unexplained[p] += err > allowed;
  double p_over = experiment_normal_tail2(max_error / bound), p_miss = experiment_normal_tail2(allowed / bound);
  v->efficient_over[p] += p_over;
  v->efficient_unexplained[p] += p_miss;
  v->efficient_log_meet[p] += log1p(-p_miss);
  if (p_miss > v->efficient_hardest_miss[p]) v->efficient_hardest_miss[p] = p_miss;
  double z = (recovered - truth) / (fabs(truth) * bound);
  v->z_sum[p] += z;
  v->z2_sum[p] += z * z;
  if (fabs(z) > v->z_max[p]) v->z_max[p] = fabs(z);
}

void experiment_verdict_print_efficient(const experiment_verdict_t *v, int p, const char *label) {
  size_t n = v->voxels[p];
  if (n == 0) return;
  printf("  %-30s %-8s over %5zu / %6.1f  not within %5zu / %6.1f  P(meet) %.3g-%.3g  z mean %+.2f  "
         "z^2 mean %.2f  max|z| %.1f / %.1f\n",
         label, hetinv_param_name((hetinv_param_t)p), v->over[p], v->efficient_over[p], v->unexplained[p],
         v->efficient_unexplained[p], exp(v->efficient_log_meet[p]), 1.0 - v->efficient_hardest_miss[p],
         v->z_sum[p] / (double)n, v->z2_sum[p] / (double)n, v->z_max[p], experiment_expected_max_abs_normal(n));
}

/* Radius `radius`'s counts of parameter p from its channel (section of
 * w columns), or false where bound.exr has none. */
static bool add_radius(experiment_verdict_t *v, int p, hetinv_image_t *bound, int radius, const float *t,
                       const float *r, const int32_t d[3]) {
  char channel[64];
  int32_t c = -1, w = 0;
  snprintf(channel, sizeof channel, "bound_local_r%d_%s", radius, hetinv_param_name((hetinv_param_t)p));
  if (hetinv_image_find_channel(bound, channel, &c) != HETINV_SUCCESS) return false;
  hetinv_image_get_size(bound, &w, NULL, NULL);
  const float *b = hetinv_image_channel_data(bound, c);
  for (int32_t z = 0; z < d[2]; ++z) {
    for (int32_t x = 0; x < d[0]; ++x) {
      size_t k = ((size_t)z * (size_t)d[1] + (size_t)(d[1] / 2)) * (size_t)d[0] + (size_t)x;
      double bk = (double)b[(size_t)z * (size_t)w + (size_t)x], truth = (double)t[k];
      if (truth == 0.0) continue;
      double err = fabs((double)r[k] - truth) / fabs(truth);
      if (!(err > VERDICT_MAX_ERROR)) continue;
      if (isnan(bk)) {
        ++v->radius_undetermined[radius][p];
      } else if (bk > 0.0 && isfinite(bk)) { /* as experiment_verdict_voxel: no light, no count */
        v->radius_unexplained[radius][p] += err > allowance(bk, VERDICT_MAX_ERROR);
      }
    }
  }
  return true;
}

static int add_param(hetinv_context_t *ctx, const char *dir, int p, hetinv_image_t *bound, bool local,
                     experiment_verdict_t *v, char *msg, size_t n) {
  const char *name = hetinv_param_name((hetinv_param_t)p);
  char path[1200], channel[64];
  int32_t dt[3], dr[3], w = 0, h = 0, c = -1;
  snprintf(channel, sizeof channel, "%s_%s", local ? "bound_local" : "bound", name);
  if (hetinv_image_find_channel(bound, channel, &c) != HETINV_SUCCESS) {
    snprintf(msg, n, "%s/bound.exr: no channel %s", dir, channel);
    return -1;
  }
  snprintf(path, sizeof path, "%s/truth_%s.vol", dir, name);
  float *t = experiment_vol_load(ctx, path, dt, msg, n);
  snprintf(path, sizeof path, "%s/recovered_%s.vol", dir, name);
  float *r = t ? experiment_vol_load(ctx, path, dr, msg, n) : NULL;
  int status = t && r ? 0 : -1;
  hetinv_image_get_size(bound, &w, &h, NULL);
  if (status == 0 && (dt[0] != dr[0] || dt[1] != dr[1] || dt[2] != dr[2] || w != dt[0] || h != dt[2])) {
    snprintf(msg, n, "%s: truth %dx%dx%d, recovery %dx%dx%d, bound section %dx%d do not match", dir,
             (int)dt[0], (int)dt[1], (int)dt[2], (int)dr[0], (int)dr[1], (int)dr[2], (int)w, (int)h);
    status = -1;
  }
  const float *b = status == 0 ? hetinv_image_channel_data(bound, c) : NULL;
  for (int32_t z = 0; status == 0 && z < dt[2]; ++z) {
    for (int32_t x = 0; x < dt[0]; ++x) {
      size_t k = ((size_t)z * (size_t)dt[1] + (size_t)(dt[1] / 2)) * (size_t)dt[0] + (size_t)x;
      double bk = (double)b[(size_t)z * (size_t)w + (size_t)x];
      experiment_verdict_voxel(v, p, (double)t[k], (double)r[k], bk, VERDICT_MAX_ERROR);
    }
  }
  if (status == 0 && p == 0) { /* the cell's radii, counted once */
    int radii = 0;
    while (local && radii < VERDICT_RADII && add_radius(v, p, bound, radii, t, r, dt)) ++radii;
    v->radii = v->cells == 0 || radii < v->radii ? radii : v->radii;
    ++v->cells;
  } else if (status == 0) {
    for (int radius = 0; radius < v->radii; ++radius) add_radius(v, p, bound, radius, t, r, dt);
  }
  free(t);
  free(r);
  return status;
}

int experiment_verdict_add(const char *dir, bool local, experiment_verdict_t *v, char *msg, size_t msg_size) {
  hetinv_context_t *ctx = NULL;
  hetinv_image_t *bound = NULL;
  char path[1200];
  snprintf(path, sizeof path, "%s/bound.exr", dir);
  if (hetinv_context_create(NULL, &ctx) != HETINV_SUCCESS) {
    snprintf(msg, msg_size, "cannot create a context: %s", hetinv_context_last_error_message(NULL));
    return -1;
  }
  int status = 0;
  if (hetinv_image_read_exr(ctx, path, &bound) != HETINV_SUCCESS) {
    snprintf(msg, msg_size, "%s: %s", path, hetinv_context_last_error_message(ctx));
    status = -1;
  }
  for (int p = 0; status == 0 && p < 3; ++p) status = add_param(ctx, dir, p, bound, local, v, msg, msg_size);
  hetinv_image_destroy(&bound);
  hetinv_context_destroy(&ctx);
  return status;
}
