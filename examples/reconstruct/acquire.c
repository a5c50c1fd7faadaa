/* Simulated acquisition (render the truth, then the sensor noise model,
 * one exposure per row as a camera would take one shot per source) and
 * measurement files. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "recon.h"

void recon_set_weights(int weighting, const double *v, const double *se, const double *render_var, double *w,
                       size_t n) {
  double peak = 0.0;
  for (size_t i = 0; i < n; ++i) peak = fmax(peak, fabs(v[i]));
  for (size_t i = 0; i < n; ++i) {
    double s;
    switch (weighting) {
      case RECON_WEIGHT_VARIANCE: s = se[i] > 0.0 ? se[i] : 1e-6 * peak; break;
      case RECON_WEIGHT_RESIDUAL: {
        double s2 = se[i] * se[i] + (render_var ? render_var[i] : 0.0);
        s = s2 > 0.0 ? sqrt(s2) : 1e-6 * peak;
        break;
      }
      case RECON_WEIGHT_RELATIVE: s = fmax(fabs(v[i]), 1e-3 * peak); break;
      default: s = 1.0; break;
    }
    w[i] = s > 0.0 ? 1.0 / (s * s) : 0.0;
  }
}

void recon_mask_unresolved(const double *v, const double *se, uint8_t *mask, size_t n, double min_snr) {
  if (!(min_snr > 0.0)) return;
  for (size_t i = 0; i < n; ++i) {
    if (v[i] < min_snr * se[i]) mask[i] = 0;
  }
}

hetinv_result_t recon_pool_errors(const double *clean, double *mc, int32_t pixels, int32_t bins) {
  const int32_t R = RECON_POOL_RADIUS;
  double *sum_var = calloc(2 * ((size_t)pixels + 1), sizeof *sum_var), *sum_value = sum_var + pixels + 1;
  if (sum_var == NULL) return HETINV_ERROR_OUT_OF_MEMORY;
  for (int32_t b = 0; b < bins; ++b) {
    const double *x = clean + (size_t)b * (size_t)pixels;
    double *s = mc + (size_t)b * (size_t)pixels;
    /* Prefix sums over the bin's image in pixel order; a value that came
     * out zero or negative still counts its variance, not its value. */
    sum_var[0] = sum_value[0] = 0.0;
    for (int32_t p = 0; p < pixels; ++p) {
      sum_var[p + 1] = sum_var[p] + s[p] * s[p];
      sum_value[p + 1] = sum_value[p] + fmax(x[p], 0.0);
    }
    for (int32_t p = 0; p < pixels; ++p) {
      int32_t lo = p > R ? p - R : 0, hi = p + R + 1 < pixels ? p + R + 1 : pixels;
      double value = sum_value[hi] - sum_value[lo];
      double ratio = value > 0.0 ? (sum_var[hi] - sum_var[lo]) / value : 0.0;
      /* Unlit neighbourhoods keep their own (zero) error. */
      s[p] = value > 0.0 ? sqrt(ratio * fmax(x[p], 0.0)) : s[p];
    }
  }
  free(sum_var);
  return HETINV_SUCCESS;
}

hetinv_result_t recon_simulate(hetinv_context_t *ctx, const recon_scene_t *sc,
                               const hetinv_medium_t *truth, recon_imaging_t *im) {
  size_t n = hetinv_measurements_value_count(im->set);
  double *clean = calloc(n, sizeof *clean), *v = calloc(n, sizeof *v);
  double *se = calloc(n, sizeof *se), *w = calloc(n, sizeof *w), *mc = calloc(n, sizeof *mc);
  uint8_t *mask = calloc(n, 1);
  /* expected_camera_errors' noise-free reference: the data's own render, or
   * with independent_errors the second one, so that nothing the weights
   * and the mask read comes from the data's draw. */
  const bool second_reference = sc->expected_camera_errors && sc->independent_errors;
  double *reference = second_reference ? calloc(n, sizeof *reference) : clean;
  hetinv_estimator_t *est = NULL;
  hetinv_result_t r = clean && v && se && w && mc && mask && reference ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &est);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)sc->truth_photons);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, RECON_TRUTH_STREAM);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, truth, im->set, clean, mc, NULL, n);
  if (r == HETINV_SUCCESS && sc->independent_errors) {
    /* mc from the second render; its values (in v for now) are used only
     * as the reference above. */
    r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, RECON_ERRORS_STREAM);
    if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, truth, im->set, second_reference ? reference : v, mc, NULL, n);
  }
  int32_t rows = hetinv_measurements_row_count(im->set);
  for (int32_t row = 0; r == HETINV_SUCCESS && row < rows; ++row) {
    size_t off = 0;
    int32_t pixels = 0, bins = 0;
    hetinv_measurements_row_layout(im->set, row, &off, &pixels, &bins);
    size_t len = (size_t)pixels * (size_t)bins;
    double exposure = 0.0;
    for (size_t i = 0; i < len; ++i) mask[off + i] = 1;
    /* Pooled at the reference's values: with a second render, the pooled
     * error of a value that came out low is not lowered with it. */
    if (sc->pooled_errors && (r = recon_pool_errors(reference + off, mc + off, pixels, bins)) != HETINV_SUCCESS) break;
    if (!sc->noise) {
      memcpy(v + off, clean + off, len * sizeof *v);
      memcpy(se + off, mc + off, len * sizeof *se);
      continue;
    }
    bool lit = false;
    hetinv_noise_model_t model = sc->noise_model;
    r = camera_shoot_row(ctx, &model, im->set, row, clean + off, v + off, se + off, &exposure, &lit);
    if (r == HETINV_SUCCESS && !lit) { /* nothing reached this row: a dark frame of read noise only */
      memset(v + off, 0, len * sizeof *v);
      for (size_t i = 0; i < len; ++i) se[off + i] = 0.0;
      /* Its exposure, and so its noise, is undefined: left out, as the
       * bound leaves it out (a zero σ would give it a weight 10¹² times
       * the brightest value's under the variance weighting). */
      memset(mask + off, 0, len);
      continue;
    }
    if (r == HETINV_SUCCESS && sc->expected_camera_errors) {
      /* The library's error is the recorded count's; this one the expected count's. */
      double read_variance = model.read_noise * model.read_noise;
      for (size_t i = 0; i < len; ++i) {
        se[off + i] = sqrt(fmax(exposure * reference[off + i], 0.0) + read_variance) / exposure;
      }
    }
    /* The clean values are themselves a Monte Carlo render: its error is
     * in the data as much as the camera's (on the built-in scene at 30000
     * photons it was 1.7x the camera's on average), so the standard error
     * stored with a value, the variance weights and the bound hold both. */
    for (size_t i = 0; r == HETINV_SUCCESS && i < len; ++i) se[off + i] = hypot(se[off + i], mc[off + i]);
    /* (4): pathlength values lost in the read noise are left out; the
     * steady-state rows stand in for them. */
    if (r == HETINV_SUCCESS && sc->config == RECON_COMBINED && bins > 1) {
      double floor_value = sc->snr_threshold * model.read_noise / exposure;
      const double *level = sc->expected_camera_errors ? reference : clean; /* as min_snr's test below */
      for (size_t i = 0; i < len; ++i) mask[off + i] = level[off + i] * 1.0 > floor_value;
    }
  }
  if (r == HETINV_SUCCESS) {
    /* The diagnostic leaves values out by their noise-free reference too:
     * a test of the recorded value keeps the dim ones the camera recorded
     * high (at 20 expected electrons and read noise 5, those kept average
     * 26 % above their expectation), and a test of the data's own render
     * the dim ones its photons made bright. */
    /* The residual's render variance: the optimizer renders sc->photons
     * per source where the data had truth_photons, so its Monte Carlo
     * variance is the data's scaled by their ratio. mc is no longer needed
     * as such and holds it. */
    double scale = (double)sc->truth_photons / (double)sc->photons;
    bool residual = sc->weighting == RECON_WEIGHT_RESIDUAL, clip_residual = sc->loss_clip_errors != RECON_CLIP_DATA;
    bool snr_residual = sc->min_snr_errors == RECON_SNR_RESIDUAL;
    for (size_t i = 0; (residual || clip_residual || snr_residual) && i < n; ++i) mc[i] = mc[i] * mc[i] * scale;
    if (snr_residual) { /* tested at the residual's error: w holds it for now */
      for (size_t i = 0; i < n; ++i) w[i] = sqrt(se[i] * se[i] + mc[i]);
    }
    recon_mask_unresolved(sc->expected_camera_errors ? reference : v, snr_residual ? w : se, mask, n, sc->min_snr);
    recon_set_weights(sc->weighting, v, se, residual ? mc : NULL, w, n);
    r = hetinv_measurements_set_values(im->set, v, se, n);
    /* The clip at c residual standard errors, c·sqrt(se² + render
     * variance), whatever the weighting (the library clips at c·s/√w): on
     * both sides, or only where the render is above the data, the side of
     * its own rare bright paths (the data's fall below). */
    if (r == HETINV_SUCCESS && clip_residual) {
      double *scales = malloc(n * sizeof *scales);
      if (scales == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
      for (size_t i = 0; scales && i < n; ++i) {
        double s = sqrt(w[i] * (se[i] * se[i] + mc[i]));
        scales[i] = s > 0.0 && isfinite(s) ? s : 1.0; /* a value of weight 0 is not in the loss */
      }
      const double *below = sc->loss_clip_errors == RECON_CLIP_RESIDUAL ? scales : NULL;
      if (r == HETINV_SUCCESS) r = hetinv_measurements_set_clip_scales(im->set, below, scales, n);
      free(scales);
    }
  }
  if (r == HETINV_SUCCESS) r = hetinv_measurements_set_weights(im->set, w, n);
  if (r == HETINV_SUCCESS) r = hetinv_measurements_set_mask(im->set, mask, n);
  hetinv_estimator_destroy(&est);
  free(clean);
  free(v);
  free(se);
  free(w);
  free(mc);
  if (reference != clean) free(reference);
  free(mask);
  return r;
}

/* The last two, the loss clip's scales, are written only where one differs from 1. */
static const char *const CHANNELS[6] = {"value", "std_error", "weight", "mask", "clip_scale_below", "clip_scale_above"};

bool recon_has_clip_scales(const hetinv_measurements_t *set) {
  size_t n = hetinv_measurements_value_count(set);
  const double *b = hetinv_measurements_clip_scales_below(set), *a = hetinv_measurements_clip_scales_above(set);
  for (size_t i = 0; i < n; ++i) {
    if (b[i] != 1.0 || a[i] != 1.0) return true;
  }
  return false;
}

hetinv_result_t recon_measurements_write(hetinv_context_t *ctx, const recon_imaging_t *im, const char *path) {
  size_t n = hetinv_measurements_value_count(im->set);
  const double *src[6] = {hetinv_measurements_values(im->set), hetinv_measurements_std_errors(im->set),
                          hetinv_measurements_weights(im->set), NULL, hetinv_measurements_clip_scales_below(im->set),
                          hetinv_measurements_clip_scales_above(im->set)};
  const uint8_t *mask = hetinv_measurements_mask(im->set);
  int channels = recon_has_clip_scales(im->set) ? 6 : 4;
  hetinv_image_t *img = NULL;
  hetinv_result_t r = hetinv_image_create(ctx, (int32_t)n, 1, channels, &img);
  for (int c = 0; r == HETINV_SUCCESS && c < channels; ++c) {
    r = hetinv_image_set_channel_name(img, c, CHANNELS[c]);
    float *dst = hetinv_image_channel_data(img, c);
    for (size_t i = 0; r == HETINV_SUCCESS && i < n; ++i) dst[i] = c != 3 ? (float)src[c][i] : (float)mask[i];
  }
  if (r == HETINV_SUCCESS) r = hetinv_image_set_attribute_string(img, "hetinv:content", "measurement set values");
  if (r == HETINV_SUCCESS) r = hetinv_image_set_attribute_int(img, "hetinv:rows", hetinv_measurements_row_count(im->set));
  if (r == HETINV_SUCCESS) r = hetinv_image_set_attribute_int(img, "hetinv:values", (int32_t)n);
  if (r == HETINV_SUCCESS) r = hetinv_image_write_exr(img, path);
  hetinv_image_destroy(&img);
  return r;
}

hetinv_result_t recon_measurements_read(hetinv_context_t *ctx, recon_imaging_t *im, const char *path,
                                        char *msg, size_t msg_size) {
  size_t n = hetinv_measurements_value_count(im->set);
  hetinv_image_t *img = NULL;
  hetinv_result_t r = hetinv_image_read_exr(ctx, path, &img);
  if (r != HETINV_SUCCESS) {
    snprintf(msg, msg_size, "%s", hetinv_context_last_error_message(ctx));
    return r;
  }
  int32_t w = 0, h = 0, rows = 0, ch[4] = {-1, -1, -1, -1};
  hetinv_image_get_size(img, &w, &h, NULL);
  hetinv_image_get_attribute_int(img, "hetinv:rows", &rows);
  if ((size_t)w * (size_t)h != n || rows != hetinv_measurements_row_count(im->set)) {
    snprintf(msg, msg_size, "%s holds %d values in %d rows; the scene's imaging configuration has %zu in %d",
             path, (int)(w * h), (int)rows, n, (int)hetinv_measurements_row_count(im->set));
    hetinv_image_destroy(&img);
    return HETINV_ERROR_INVALID_ARGUMENT;
  }
  for (int c = 0; c < 4; ++c) {
    if (hetinv_image_find_channel(img, CHANNELS[c], &ch[c]) != HETINV_SUCCESS) {
      snprintf(msg, msg_size, "%s has no channel \"%s\"", path, CHANNELS[c]);
      hetinv_image_destroy(&img);
      return HETINV_ERROR_INVALID_ARGUMENT;
    }
  }
  int32_t scale_ch[2] = {-1, -1}; /* optional: all 1 without them */
  for (int c = 0; c < 2; ++c) {
    if (hetinv_image_find_channel(img, CHANNELS[4 + c], &scale_ch[c]) != HETINV_SUCCESS) scale_ch[c] = -1;
  }
  double *v = calloc(n, sizeof *v), *se = calloc(n, sizeof *se), *wt = calloc(n, sizeof *wt);
  double *cs = calloc(2 * n, sizeof *cs); /* below, then above */
  uint8_t *mask = calloc(n, 1);
  r = v && se && wt && cs && mask ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  bool mask_refused = false;
  for (size_t i = 0; r == HETINV_SUCCESS && i < n; ++i) {
    v[i] = (double)hetinv_image_channel_data(img, ch[0])[i];
    se[i] = (double)hetinv_image_channel_data(img, ch[1])[i];
    wt[i] = (double)hetinv_image_channel_data(img, ch[2])[i];
    float keep = hetinv_image_channel_data(img, ch[3])[i];
    if (keep != 0.0f && keep != 1.0f) { /* NaN too: was read as 1 */
      snprintf(msg, msg_size, "%s: mask[%zu] is %g; it must be 0 (left out of the loss) or 1 (kept)", path, i,
               (double)keep);
      r = HETINV_ERROR_INVALID_ARGUMENT;
      mask_refused = true;
      break;
    }
    mask[i] = keep == 1.0f;
    for (int c = 0; c < 2; ++c) {
      cs[c * n + i] = scale_ch[c] >= 0 ? (double)hetinv_image_channel_data(img, scale_ch[c])[i] : 1.0;
    }
  }
  if (r == HETINV_SUCCESS) r = hetinv_measurements_set_values(im->set, v, se, n);
  if (r == HETINV_SUCCESS) r = hetinv_measurements_set_weights(im->set, wt, n);
  if (r == HETINV_SUCCESS) r = hetinv_measurements_set_clip_scales(im->set, cs, cs + n, n);
  if (r == HETINV_SUCCESS) r = hetinv_measurements_set_mask(im->set, mask, n);
  if (r != HETINV_SUCCESS && !mask_refused) snprintf(msg, msg_size, "%s: %s", path, hetinv_context_last_error_message(ctx));
  free(v);
  free(se);
  free(wt);
  free(cs);
  free(mask);
  hetinv_image_destroy(&img);
  return r;
}
