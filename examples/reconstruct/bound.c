/* The Cramér–Rao bound of a scene's configuration at its ground truth:
 * what the measurements can determine, per voxel and parameter, before
 * (or beside) a reconstruction. Public API only. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "recon.h"

/* The clean values come from recon_simulate's stream, with the data's
 * photons or the bound's if more: at fewer than the data's, pixels the
 * data see come out dark and their floor variance overweights them (at
 * the paper's size, 1000 photons per emitter made sqrt(1/F_kk) 2.4x too
 * small). A forward render costs a fraction of the tangent passes. */
#define RECON_TRUTH_STREAM 40000

/* Per value, the acquisition model's variance at the clean value:
 * (E·I + r²)/E² with the row's exposure E (the model's, or automatic as in
 * recon_simulate); mask 0 for rows no light reaches (automatic exposure
 * is undefined there and they carry no information) and for values whose
 * standard error exceeds value/min_snr (left out of the loss too). Without
 * noise in the scene the model is still what a camera would add. */
static hetinv_result_t variances_of(hetinv_context_t *ctx, const recon_scene_t *sc,
                                    const hetinv_medium_t *truth, recon_imaging_t *im, int64_t photons,
                                    double *var, uint8_t *mask) {
  size_t n = hetinv_measurements_value_count(im->set);
  double *clean = calloc(n, sizeof *clean), *scratch = calloc(n, sizeof *scratch);
  double *mc = calloc(n, sizeof *mc);
  hetinv_estimator_t *est = NULL;
  hetinv_result_t r = clean && scratch && mc ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &est);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)photons);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, RECON_TRUTH_STREAM);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, truth, im->set, clean, mc, NULL, n);
  /* The simulated data are a render at the scene's photons: its Monte Carlo
   * variance, scaled from this render's, is part of their noise. */
  const double mc_scale = (double)photons / (double)sc->truth_photons;
  const double render_scale = (double)photons / (double)sc->photons; /* the optimizer's render */
  const uint8_t *set_mask = hetinv_measurements_mask(im->set);
  int32_t rows = hetinv_measurements_row_count(im->set);
  for (int32_t row = 0; r == HETINV_SUCCESS && row < rows; ++row) {
    size_t off = 0;
    int32_t pixels = 0, bins = 0;
    hetinv_measurements_row_layout(im->set, row, &off, &pixels, &bins);
    size_t len = (size_t)pixels * (size_t)bins;
    bool lit = false;
    for (size_t i = 0; i < len; ++i) lit = lit || clean[off + i] > 0.0;
    if (!lit) {
      for (size_t i = 0; i < len; ++i) {
        var[off + i] = 1.0;
        mask[off + i] = 0;
      }
      continue;
    }
    /* The data's errors, pooled as recon_simulate pools them. */
    if (sc->pooled_errors && (r = recon_pool_errors(clean + off, mc + off, pixels, bins)) != HETINV_SUCCESS) break;
    /* The shot's exposure, as the acquisition takes it. */
    double exposure = 0.0;
    r = camera_shoot_row(ctx, &sc->noise_model, im->set, row, clean + off, scratch + off, NULL, &exposure, &lit);
    double read2 = sc->noise_model.read_noise * sc->noise_model.read_noise;
    for (size_t i = 0; r == HETINV_SUCCESS && i < len; ++i) {
      double e = exposure * clean[off + i] + read2;
      /* A noiseless camera (read noise 0) still counts photons: at least
       * one electron's variance keeps dark pixels finite. */
      var[off + i] = (e > 1.0 ? e : 1.0) / (exposure * exposure) + mc[off + i] * mc[off + i] * mc_scale;
      /* As the loss: a value the data (or with min_snr_errors "residual",
       * the data and the optimizer's render) would not resolve is left out. */
      double tested = var[off + i];
      if (sc->min_snr_errors == RECON_SNR_RESIDUAL) tested += mc[off + i] * mc[off + i] * render_scale;
      mask[off + i] = set_mask[off + i] && !(clean[off + i] < sc->min_snr * sqrt(tested));
    }
  }
  hetinv_estimator_destroy(&est);
  free(clean);
  free(scratch);
  free(mc);
  return r;
}

/* From measured files: the standard errors given with the values
 * (acquisition.std_errors) are their noise; a value without one (σ = 0) or
 * masked carries no information here. */
static void variances_given(const recon_imaging_t *im, double *var, uint8_t *mask) {
  size_t n = hetinv_measurements_value_count(im->set);
  const double *se = hetinv_measurements_std_errors(im->set);
  const uint8_t *set_mask = hetinv_measurements_mask(im->set);
  for (size_t i = 0; i < n; ++i) {
    bool known = se != NULL && se[i] > 0.0 && (set_mask == NULL || set_mask[i]);
    var[i] = known ? se[i] * se[i] : 1.0;
    mask[i] = known;
  }
}

static int compare_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static void summarise(recon_bound_t *b, size_t voxels) {
  double *sorted = calloc(voxels, sizeof *sorted);
  for (int p = 0; p < 3; ++p) {
    size_t n = 0;
    double sum = 0.0, mx = 0.0;
    b->infinite[p] = b->undefined[p] = 0;
    for (size_t v = 0; v < voxels; ++v) {
      double x = b->rel[p][v];
      if (isinf(x)) {
        ++b->infinite[p];
      } else if (isnan(x)) {
        ++b->undefined[p];
      } else {
        if (sorted) sorted[n] = x;
        ++n;
        sum += x;
        mx = fmax(mx, x);
      }
    }
    b->mean[p] = n ? sum / (double)n : (double)NAN;
    double se_sum = 0.0;
    for (size_t v = 0; v < voxels; ++v) se_sum += isfinite(b->rel[p][v]) ? b->rel_se[p][v] : 0.0;
    b->se_mean[p] = n ? se_sum / (double)n : (double)NAN;
    b->max[p] = n ? mx : (double)NAN;
    double lo_sum = 0.0;
    size_t lo_n = 0;
    for (size_t v = 0; v < voxels; ++v) {
      if (isfinite(b->lower[p][v])) {
        lo_sum += b->lower[p][v];
        ++lo_n;
      }
    }
    b->lower_mean[p] = lo_n ? lo_sum / (double)lo_n : (double)NAN;
    b->median[p] = (double)NAN;
    if (sorted && n) {
      qsort(sorted, n, sizeof *sorted, compare_double);
      b->median[p] = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
    }
  }
  free(sorted);
}

/* Mean, max and undetermined count of the local bound at one radius. */
static void local_summary(recon_bound_t *b, int32_t radius, double *const rel[3], size_t voxels) {
  for (int p = 0; p < 3; ++p) {
    double sum = 0.0, mx = 0.0;
    size_t m = 0;
    for (size_t v = 0; v < voxels; ++v) {
      double x = rel[p][v];
      if (!isfinite(x)) continue;
      sum += x;
      mx = fmax(mx, x);
      ++m;
    }
    b->local_mean[radius][p] = m ? sum / (double)m : (double)NAN;
    b->local_max[radius][p] = m ? mx : (double)NAN;
    b->local_undefined[radius][p] = voxels - m;
  }
}

/* The local bounds of recon_bound_t from F̂ (the replicates of
 * hetinv_estimator_crb once more: same estimator, same streams). */
static hetinv_result_t local_bounds(hetinv_estimator_t *est, const hetinv_medium_t *truth, recon_imaging_t *im,
                                    const double *var, const hetinv_param_map_t *map, const double *pi,
                                    int32_t replicates, recon_bound_t *b) {
  size_t n = hetinv_measurements_value_count(im->set), k = hetinv_param_map_size(map);
  size_t voxels = hetinv_medium_voxel_count(truth);
  double *F = calloc(k * k, sizeof *F), *sd = calloc(k, sizeof *sd);
  double *rel[3] = {NULL, NULL, NULL};
  hetinv_result_t r = F && sd ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    b->local[p] = calloc(voxels, sizeof(double));
    rel[p] = calloc(voxels, sizeof(double));
    if (b->local[p] == NULL || rel[p] == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  if (r == HETINV_SUCCESS) r = hetinv_estimator_fisher(est, truth, im->set, var, n, map, replicates, F, NULL, k);
  for (int32_t radius = 0; r == HETINV_SUCCESS && radius < RECON_LOCAL_RADII; ++radius) {
    r = hetinv_fisher_local_crb(map, F, k, radius, sd);
    if (r == HETINV_ERROR_INVALID_ARGUMENT) { /* windows past the dense limit: stop at the last */
      r = HETINV_SUCCESS;
      break;
    }
    for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) {
      hetinv_param_t p = HETINV_PARAM_SIGMA_A;
      size_t cell = 0;
      r = hetinv_param_map_entry(map, i, &p, &cell);
      rel[p][cell] = sd[i] / fabs(pi[i]);
    }
    if (r != HETINV_SUCCESS) break;
    local_summary(b, radius, rel, voxels);
    for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
      b->local_at[radius][p] = malloc(voxels * sizeof(double));
      if (b->local_at[radius][p] == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
      else memcpy(b->local_at[radius][p], rel[p], voxels * sizeof(double));
    }
    if (r != HETINV_SUCCESS) break;
    b->local_radii = radius + 1;
    bool as_determined = true;
    for (int p = 0; p < 3; ++p) as_determined = as_determined && b->local_undefined[radius][p] <= b->local_undefined[0][p];
    if (as_determined) {
      b->local_best = radius;
      for (int p = 0; p < 3; ++p) memcpy(b->local[p], rel[p], voxels * sizeof(double));
    }
  }
  for (int p = 0; p < 3; ++p) free(rel[p]);
  free(F);
  free(sd);
  return r;
}

/* Maps past the dense matrix's limit: the local bound at radius 0 from
 * F's blocks on its diagonal (hetinv_estimator_fisher_blocks, matrix-free),
 * into b->local; sd NaN (the full bound is not estimated) and lower
 * sqrt(1/F_kk) from the blocks' diagonals. */
static hetinv_result_t block_bounds(hetinv_estimator_t *est, const hetinv_medium_t *truth, recon_imaging_t *im,
                                    const double *var, const hetinv_param_map_t *map, const double *pi,
                                    int32_t replicates, int32_t spacing, double *sd, double *lower,
                                    recon_bound_t *b) {
  size_t n = hetinv_measurements_value_count(im->set), k = hetinv_param_map_size(map);
  size_t voxels = hetinv_medium_voxel_count(truth);
  const size_t P = 3; /* an identity map of all three parameters */
  double *B = calloc(voxels * P * P, sizeof *B), *local = calloc(k, sizeof *local);
  double *rel[3] = {NULL, NULL, NULL};
  hetinv_result_t r = B && local ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    b->local[p] = rel[p] = calloc(voxels, sizeof(double));
    if (rel[p] == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  if (r == HETINV_SUCCESS) {
    r = hetinv_estimator_fisher_blocks(est, truth, im->set, var, n, map, spacing, replicates, B, NULL, k);
  }
  if (r == HETINV_SUCCESS) r = hetinv_fisher_blocks_crb(map, B, k, local);
  for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) {
    hetinv_param_t p = HETINV_PARAM_SIGMA_A;
    size_t cell = 0;
    r = hetinv_param_map_entry(map, i, &p, &cell);
    double f = B[(cell * P + (size_t)p) * P + (size_t)p];
    rel[p][cell] = local[i] / fabs(pi[i]);
    sd[i] = (double)NAN;
    lower[i] = f > 0.0 ? 1.0 / sqrt(f) : (f == 0.0 ? (double)INFINITY : (double)NAN);
  }
  if (r == HETINV_SUCCESS) {
    local_summary(b, 0, rel, voxels);
    b->local_radii = 1;
    b->local_best = 0;
    b->spacing = spacing;
  }
  free(B);
  free(local);
  return r;
}

hetinv_result_t recon_bound_compute(hetinv_context_t *ctx, const recon_scene_t *sc,
                                    const hetinv_medium_t *truth, recon_imaging_t *im,
                                    int64_t photons, int32_t replicates, recon_bound_t *b) {
  memset(b, 0, sizeof *b);
  double t0 = recon_now();
  size_t n = hetinv_measurements_value_count(im->set), voxels = hetinv_medium_voxel_count(truth);
  hetinv_param_map_t *map = NULL;
  hetinv_estimator_t *est = NULL;
  double *var = calloc(n, sizeof *var), *sd = NULL, *se = NULL, *pi = NULL, *lower = NULL;
  uint8_t *mask = calloc(n, 1), *saved_mask = calloc(n, 1);
  hetinv_result_t r = var && mask && saved_mask ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  if (r == HETINV_SUCCESS) r = hetinv_param_map_create_identity(truth, HETINV_FREE_ALL, &map);
  size_t k = map ? hetinv_param_map_size(map) : 0;
  if (r == HETINV_SUCCESS) {
    sd = calloc(k, sizeof *sd);
    lower = calloc(k, sizeof *lower);
    se = calloc(k, sizeof *se);
    pi = calloc(k, sizeof *pi);
    for (int p = 0; p < 3; ++p) {
      b->rel[p] = calloc(voxels, sizeof(double));
      b->rel_se[p] = calloc(voxels, sizeof(double));
      b->lower[p] = calloc(voxels, sizeof(double));
      if (!b->rel[p] || !b->rel_se[p] || !b->lower[p]) r = HETINV_ERROR_OUT_OF_MEMORY;
    }
    if (!sd || !se || !pi || !lower) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  if (r == HETINV_SUCCESS) {
    memcpy(saved_mask, hetinv_measurements_mask(im->set), n);
    if (sc->render_scene[0] != '\0') {
      variances_given(im, var, mask);
    } else {
      r = variances_of(ctx, sc, truth, im, photons > sc->truth_photons ? photons : sc->truth_photons, var, mask);
    }
  }
  if (r == HETINV_SUCCESS) r = hetinv_param_map_extract(map, truth, pi, k);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &est);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)photons);
  if (r == HETINV_SUCCESS && sc->batches > 0) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_BATCHES, sc->batches);
  if (r == HETINV_SUCCESS) r = hetinv_measurements_set_mask(im->set, mask, n);
  if (r == HETINV_SUCCESS && k > HETINV_FISHER_MAX_ENTRIES) {
    r = block_bounds(est, truth, im, var, map, pi, replicates, sc->bound_spacing > 0 ? sc->bound_spacing : 2,
                     sd, lower, b);
    for (size_t i = 0; i < k; ++i) se[i] = (double)NAN;
    hetinv_result_t back = hetinv_measurements_set_mask(im->set, saved_mask, n);
    if (r == HETINV_SUCCESS) r = back;
  } else if (r == HETINV_SUCCESS) {
    r = hetinv_estimator_crb(est, truth, im->set, var, n, map, replicates, sd, se, lower, k,
                             &b->positive_definite);
    /* Not positive definite (at the paper's size, 1875 entries, it is not
     * at any affordable photon count): the same replicates once more give
     * F̂ itself, and from it the local bounds. */
    if (r == HETINV_SUCCESS && !b->positive_definite) r = local_bounds(est, truth, im, var, map, pi, replicates, b);
    hetinv_result_t back = hetinv_measurements_set_mask(im->set, saved_mask, n);
    if (r == HETINV_SUCCESS) r = back;
  }
  for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) {
    hetinv_param_t p = HETINV_PARAM_SIGMA_A;
    size_t cell = 0;
    r = hetinv_param_map_entry(map, i, &p, &cell);
    b->rel[p][cell] = sd[i] / fabs(pi[i]);
    b->rel_se[p][cell] = se[i] / fabs(pi[i]);
    b->lower[p][cell] = lower[i] / fabs(pi[i]);
  }
  if (r == HETINV_SUCCESS) {
    summarise(b, voxels);
    b->done = true;
    b->photons = photons;
    b->replicates = replicates;
    b->entries = k;
    b->seconds = recon_now() - t0;
  }
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  free(var);
  free(mask);
  free(saved_mask);
  free(sd);
  free(se);
  free(pi);
  free(lower);
  if (r != HETINV_SUCCESS) recon_bound_release(b);
  return r;
}

void recon_bound_release(recon_bound_t *b) {
  for (int p = 0; p < 3; ++p) {
    free(b->rel[p]);
    free(b->rel_se[p]);
    free(b->lower[p]);
    free(b->local[p]);
    b->rel[p] = b->rel_se[p] = b->lower[p] = b->local[p] = NULL;
    for (int32_t radius = 0; radius < RECON_LOCAL_RADII; ++radius) {
      free(b->local_at[radius][p]);
      b->local_at[radius][p] = NULL;
    }
  }
  b->done = false;
}

void recon_bound_print(const recon_bound_t *b, FILE *f) {
  fprintf(f, "\nCramer-Rao bound at the %s: predicted relative standard deviation of an unbiased\n"
             "estimate, per voxel (%lld photons per emitter, %d replicates, %.1f s):\n",
          b->at_recovery ? "recovery (no truth given)" : "truth", (long long)b->photons, (int)b->replicates,
          b->seconds);
  if (b->spacing > 0) {
    fprintf(f, "  %zu entries, past the dense Fisher matrix's %d: only the local bound at radius 0, from\n"
               "  F's blocks on its diagonal (matrix-free, probes on classes of voxels %d apart)\n",
            b->entries, HETINV_FISHER_MAX_ENTRIES, (int)b->spacing);
  } else if (!b->positive_definite) {
    fprintf(f, "  the estimated Fisher matrix is not positive definite: the measurements cannot tell\n"
               "  some parameters apart at this photon count (more --bound-photons, or a coarser map)\n");
  }
  if (b->spacing == 0) fprintf(f, "  parameter   mean       median     max        mean s.e.  undetermined\n");
  for (int p = 0; b->spacing == 0 && p < 3; ++p) {
    fprintf(f, "  %-9s %8.3g %%  %8.3g %%  %8.3g %%  %8.2g %%  %zu\n", hetinv_param_name(p),
            100.0 * b->mean[p], 100.0 * b->median[p], 100.0 * b->max[p], 100.0 * b->se_mean[p],
            b->infinite[p] + b->undefined[p]);
  }
  fprintf(f, "  lower bound sqrt(1/F_kk) (each value alone, the others known), mean:");
  for (int p = 0; p < 3; ++p) fprintf(f, " %s %.3g %%", hetinv_param_name(p), 100.0 * b->lower_mean[p]);
  fprintf(f, "\n");
  if (b->local_radii > 0) {
    fprintf(f, "  local bound (the voxels within the radius unknown, the others known; a lower bound\n"
               "  that grows with the radius), mean / max:\n");
    for (int32_t radius = 0; radius < b->local_radii; ++radius) {
      fprintf(f, "    radius %d:", (int)radius);
      for (int p = 0; p < 3; ++p) {
        fprintf(f, "  %s %.3g / %.3g %%", hetinv_param_name(p), 100.0 * b->local_mean[radius][p],
                100.0 * b->local_max[radius][p]);
        if (b->local_undefined[radius][p]) fprintf(f, " (%zu undetermined)", b->local_undefined[radius][p]);
      }
      fprintf(f, "%s\n", radius == b->local_best ? "  <- in the maps" : "");
    }
  }
}

/* The bound's files in the output folder: bound.exr (param < 0) or the
 * parameter's PNG preview. Named here only, for the writer and for the
 * removal of a stale set (recon_bound_run under MPI). */
static void bound_file(char *path, size_t size, const recon_scene_t *sc, int param) {
  if (param < 0) {
    snprintf(path, size, "%s/bound.exr", sc->output);
  } else {
    snprintf(path, size, "%s/bound_%s.png", sc->output, hetinv_param_name((hetinv_param_t)param));
  }
}

/* Value of a per-voxel array at section pixel (x, z): the middle y slice. */
static double section(const double *a, const int32_t d[3], int32_t x, int32_t z) {
  return a[((size_t)z * (size_t)d[1] + (size_t)(d[1] / 2)) * (size_t)d[0] + (size_t)x];
}

hetinv_result_t recon_bound_write(hetinv_context_t *ctx, const recon_scene_t *sc,
                                  const hetinv_medium_t *truth, const recon_bound_t *b) {
  int32_t d[3];
  hetinv_medium_get_dims(truth, d);
  char path[1200];
  hetinv_image_t *img = NULL;
  const int kinds_n = b->local_radii > 0 ? 4 : 3;
  const int radii_n = b->local_at[0][0] != NULL ? (int)b->local_radii : 0; /* only from the dense F̂ */
  hetinv_result_t r = hetinv_image_create(ctx, d[0], d[2], 3 * (kinds_n + radii_n), &img);
  static const char *const kinds[4] = {"bound", "bound_std_error", "bound_lower", "bound_local"};
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    const double *src[4] = {b->rel[p], b->rel_se[p], b->lower[p], b->local[p]};
    for (int which = 0; r == HETINV_SUCCESS && which < kinds_n + radii_n; ++which) {
      char name[64];
      if (which < kinds_n) {
        snprintf(name, sizeof name, "%s_%s", kinds[which], hetinv_param_name(p));
      } else {
        snprintf(name, sizeof name, "bound_local_r%d_%s", which - kinds_n, hetinv_param_name(p));
      }
      const double *a = which < kinds_n ? src[which] : b->local_at[which - kinds_n][p];
      int32_t c = (kinds_n + radii_n) * p + which;
      r = hetinv_image_set_channel_name(img, c, name);
      float *px = hetinv_image_channel_data(img, c);
      for (int32_t z = 0; z < d[2]; ++z) {
        for (int32_t x = 0; x < d[0]; ++x) {
          px[(size_t)z * (size_t)d[0] + (size_t)x] = (float)section(a, d, x, z);
        }
      }
    }
  }
  if (r == HETINV_SUCCESS) {
    r = hetinv_image_set_attribute_string(img, "hetinv:content",
                                          "Cramer-Rao bound: relative standard deviation sd/value at the "
                                          "truth, its jackknife error, the lower bound sqrt(1/F_kk)/value and, "
                                          "where F is not positive definite, the local bound of the largest "
                                          "radius that determines as many voxels as radius 0, and the local "
                                          "bound at each radius computed (bound_local_r<N>); x-z section at "
                                          "the middle of y; row = z");
  }
  bound_file(path, sizeof path, sc, -1);
  if (r == HETINV_SUCCESS) r = hetinv_image_write_exr(img, path);
  hetinv_image_destroy(&img);
  /* PNG previews, z up, on a common scale per parameter from 0 to the
   * largest finite bound (infinite ones at the top of the scale). */
  int32_t s = 256 / d[0] > 1 ? 256 / d[0] : 1;
  for (int p = 0; r == HETINV_SUCCESS && p < 3; ++p) {
    /* Without a positive definite F̂, the local bound is what there is. */
    const double *rel = b->positive_definite || b->local_radii == 0 ? b->rel[p] : b->local[p];
    double top = rel == b->rel[p] ? b->max[p] : b->local_max[b->local_best][p];
    double hi = isfinite(top) && top > 0.0 ? top : 1.0;
    r = hetinv_image_create(ctx, d[0] * s, d[2] * s, 1, &img);
    if (r != HETINV_SUCCESS) break;
    float *px = hetinv_image_channel_data(img, 0);
    for (int32_t y = 0; y < d[2] * s; ++y) {
      for (int32_t x = 0; x < d[0] * s; ++x) {
        double v = section(rel, d, x / s, d[2] - 1 - y / s);
        px[(size_t)y * (size_t)(d[0] * s) + (size_t)x] = (float)(isnan(v) ? 0.0 : fmin(v, hi));
      }
    }
    bound_file(path, sizeof path, sc, p);
    r = hetinv_image_write_png(img, 0, path, 0.0, hi, HETINV_COLORMAP_VIRIDIS);
    hetinv_image_destroy(&img);
  }
  return r;
}

void recon_bound_attach(const recon_bound_t *b, const hetinv_medium_t *truth,
                        const hetinv_medium_t *rec, recon_errors_t *e) {
  e->has_bound = b->done;
  size_t voxels = hetinv_medium_voxel_count(truth);
  for (int p = 0; p < 3; ++p) {
    /* Past the dense limit only the local bound exists (a lower bound of
     * the bound): the ratios are to it. */
    const double *rel = recon_bound_per_voxel(b, p);
    double mean = b->spacing > 0 ? b->local_mean[0][p] : b->mean[p];
    e->bound_mean[p] = b->done ? mean : (double)NAN;
    e->achieved_over_bound[p] = b->done ? e->mean[p] / mean : (double)NAN;
    e->max_over_bound[p] = b->done ? 0.0 : (double)NAN;
    e->over_2x_bound[p] = e->bounded[p] = 0;
    const double *t = hetinv_medium_grid(truth, p), *x = hetinv_medium_grid(rec, p);
    double squares = 0.0;
    for (size_t v = 0; b->done && v < voxels; ++v) {
      if (!isfinite(rel[v]) || !(rel[v] > 0.0)) continue;
      double ratio = fabs(x[v] - t[v]) / fabs(t[v]) / rel[v];
      e->max_over_bound[p] = fmax(e->max_over_bound[p], ratio);
      e->over_2x_bound[p] += ratio > 2.0;
      squares += ratio * ratio;
      ++e->bounded[p];
    }
    e->rms_over_bound[p] = e->bounded[p] > 0 ? sqrt(squares / (double)e->bounded[p]) : (double)NAN;
    if (e->bounded[p] == 0) e->max_over_bound[p] = (double)NAN; /* no voxel has a bound */
  }
}

int recon_bound_run(const char *prog, hetinv_context_t *ctx, const recon_scene_t *sc,
                    const hetinv_medium_t *truth, recon_imaging_t *im, int64_t photons,
                    int32_t replicates, bool root, bool at_recovery, recon_bound_t *b) {
  memset(b, 0, sizeof *b);
  if (hetinv_context_rank_count(ctx) > 1) {
    if (root) {
      /* A serial run's bound files in the same folder would sit beside
       * this run's recovery as if they were its own. */
      char path[1200]; /* as recon_bound_write's: the output (1023 bytes) and a name */
      for (int p = -1; p < 3; ++p) {
        bound_file(path, sizeof path, sc, p);
        remove(path);
      }
      fprintf(stderr, "%s: warning: the bound is not computed with several MPI ranks: no bound.exr, and "
              "errors.csv without the bound's columns (run --bound-only on one rank for it)\n", prog);
    }
    return 0;
  }
  if (recon_bound_compute(ctx, sc, truth, im, photons, replicates, b) != HETINV_SUCCESS) {
    return recon_fail(prog, ctx, "bound");
  }
  b->at_recovery = at_recovery;
  if (!root) return 0;
  recon_bound_print(b, stdout);
  /* The caller says "wrote" once every file of the run is written. */
  if (recon_bound_write(ctx, sc, truth, b) != HETINV_SUCCESS) return recon_fail(prog, ctx, "bound maps");
  return 0;
}
