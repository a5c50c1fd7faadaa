/* The data-or-optimizer test by the loss (fit_check.h).
 *
 * A recovery that misses the truth either fits the data better than the
 * truth does (then the data, at their noise, prefer it: no optimizer can do
 * better on this loss) or worse (then the optimizer stopped short of the
 * data's optimum). The local bound cannot tell these apart where the
 * confusion is longer than its window; the loss can. */
#include "fit_check.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "stored_cell.h"

const double FIT_CHECK_TAILS[3] = {3.0, 10.0, 100.0};

/* fit_check_t.beyond and beyond10_share of a render against the data. */
static void tails(const hetinv_measurements_t *set, const double *rendered, fit_check_t *out) {
  size_t n = hetinv_measurements_value_count(set);
  const double *data = hetinv_measurements_values(set), *w = hetinv_measurements_weights(set);
  const uint8_t *mask = hetinv_measurements_mask(set);
  double all = 0.0, far = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (!mask[i] || !(w[i] > 0.0)) continue;
    double z = sqrt(w[i]) * fabs(rendered[i] - data[i]);
    for (int j = 0; j < 3; ++j) out->beyond[j] += z > FIT_CHECK_TAILS[j];
    all += z * z;
    if (z > FIT_CHECK_TAILS[1]) far += z * z;
  }
  out->beyond10_share = all > 0.0 ? far / all : 0.0;
}

/* A stream no optimizer iteration or simulated acquisition uses. */
#define FIT_CHECK_STREAM 60000

/* Σ mask·w·((I − Ī)² − s²) of value i alone (misfit()'s term). */
static double misfit_term(const hetinv_measurements_t *set, const double *rendered, const double *se, size_t i) {
  const double *data = hetinv_measurements_values(set), *w = hetinv_measurements_weights(set);
  if (!hetinv_measurements_mask(set)[i] || !(w[i] > 0.0)) return 0.0;
  double r = rendered[i] - data[i];
  return w[i] * (r * r - se[i] * se[i]);
}

/* Σ mask·w·((I − Ī)² − s²), s the render's standard error, and its
 * standard error by the delta method (values taken as independent); each
 * value's share of the variance goes to var_share. */
static void misfit(const hetinv_measurements_t *set, const double *rendered, const double *se, double *sum,
                   double *sum_se, double *var_share) {
  size_t n = hetinv_measurements_value_count(set);
  const double *data = hetinv_measurements_values(set), *w = hetinv_measurements_weights(set);
  const uint8_t *mask = hetinv_measurements_mask(set);
  double s = 0.0, var = 0.0;
  for (size_t i = 0; i < n; ++i) {
    var_share[i] = 0.0;
    if (!mask[i] || !(w[i] > 0.0)) continue;
    double r = rendered[i] - data[i], d = 2.0 * w[i] * r * se[i], q = w[i] * se[i] * se[i];
    s += misfit_term(set, rendered, se, i);
    var_share[i] = d * d + 2.0 * q * q;
    var += var_share[i];
  }
  *sum = s;
  *sum_se = sqrt(var);
}

/* The largest shares of the difference's variance (fit_check_t.worst,
 * top10_share), and the difference without the ten largest
 * (trimmed_difference, trimmed_se); out->truth and out->recovery are set. */
static void find_worst(const hetinv_measurements_t *set, const double *pt, const double *pr, const double *render,
                       const double *render_se, const double *rec, const double *rec_se, double var,
                       fit_check_t *out) {
  size_t n = hetinv_measurements_value_count(set);
  double top[10] = {0};
  size_t top_at[10] = {0};
  size_t worst = 0;
  for (size_t i = 0; i < n; ++i) {
    double v = pt[i] + pr[i];
    if (v > pt[worst] + pr[worst]) worst = i;
    if (v > top[9]) { /* insertion into the ten largest */
      int j = 9;
      while (j > 0 && top[j - 1] < v) {
        top[j] = top[j - 1];
        top_at[j] = top_at[j - 1];
        --j;
      }
      top[j] = v;
      top_at[j] = i;
    }
  }
  /* The whole difference and its variance less the ten values' terms. */
  double diff = out->recovery - out->truth, diff_var = var;
  for (int j = 0; j < 10; ++j) {
    if (!(top[j] > 0.0)) continue;
    size_t i = top_at[j];
    diff -= misfit_term(set, rec, rec_se, i) - misfit_term(set, render, render_se, i);
    diff_var -= pt[i] + pr[i];
  }
  out->trimmed_difference = diff;
  out->trimmed_se = sqrt(fmax(diff_var, 0.0));
  double sum = 0.0;
  for (int j = 0; j < 10; ++j) sum += top[j];
  out->top10_share = var > 0.0 ? sum / var : 0.0;
  out->worst.share = var > 0.0 ? (pt[worst] + pr[worst]) / var : 0.0;
  int32_t rows = hetinv_measurements_row_count(set);
  for (int32_t row = 0; row < rows; ++row) {
    size_t off = 0;
    int32_t pixels = 0, bins = 0;
    hetinv_measurements_row_layout(set, row, &off, &pixels, &bins);
    if (worst >= off && worst < off + (size_t)pixels * (size_t)bins) {
      out->worst.row = row;
      out->worst.bins = bins > 1;
      break;
    }
  }
  out->worst.data = hetinv_measurements_values(set)[worst];
  out->worst.data_se = hetinv_measurements_std_errors(set)[worst];
  out->worst.render = render[worst];
  out->worst.render_se = render_se[worst];
}

/* One value's term of the run's loss, as hetinv_estimator_loss_gradient()
 * documents it: w·r² within the clip (√w·|r| <= clip), 2·clip·√w·|r| − clip²
 * beyond; clip 0 is least squares. Within the clip the render's own
 * variance s² is taken out (E[w·r²] = w·(r̄² + s²)), as the misfit does:
 * otherwise whichever medium renders with less Monte Carlo noise would
 * look the better fit. */
static double loss_term(double w, double r, double s, double clip) {
  double z = sqrt(w) * fabs(r);
  return clip > 0.0 && z > clip ? 2.0 * clip * z - clip * clip : z * z - w * s * s;
}

/* The clip of value i on the side of its residual r (the set's scales). */
static double clip_of(const hetinv_measurements_t *set, size_t i, double r, double clip) {
  const double *scale = r > 0.0 ? hetinv_measurements_clip_scales_above(set) : hetinv_measurements_clip_scales_below(set);
  return clip * scale[i];
}

static double run_loss(const hetinv_measurements_t *set, const double *rendered, const double *se, double clip) {
  size_t n = hetinv_measurements_value_count(set);
  const double *data = hetinv_measurements_values(set), *w = hetinv_measurements_weights(set);
  const uint8_t *mask = hetinv_measurements_mask(set);
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    double r = rendered[i] - data[i];
    if (mask[i] && w[i] > 0.0) sum += loss_term(w[i], r, se[i], clip_of(set, i, r, clip));
  }
  return sum;
}

/* fit_check_t.loss_*: pairs of renders on streams FIT_CHECK_STREAM + 1 + j,
 * into it, ir with their standard errors st, sr (n values each). */
static hetinv_result_t loss_pairs(hetinv_estimator_t *est, const recon_scene_t *sc, const hetinv_medium_t *truth,
                                  const hetinv_medium_t *rec, const hetinv_measurements_t *set, int32_t replicates,
                                  double *it, double *st, double *ir, double *sr, fit_check_t *out) {
  size_t n = hetinv_measurements_value_count(set);
  double sum = 0.0, sq = 0.0, truth_sum = 0.0;
  hetinv_result_t r = HETINV_SUCCESS;
  for (int32_t j = 0; r == HETINV_SUCCESS && j < replicates; ++j) {
    r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, FIT_CHECK_STREAM + 1 + j);
    if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, truth, set, it, st, NULL, n);
    if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, rec, set, ir, sr, NULL, n);
    if (r != HETINV_SUCCESS) break;
    double lt = run_loss(set, it, st, sc->loss_clip), d = run_loss(set, ir, sr, sc->loss_clip) - lt;
    truth_sum += lt;
    sum += d;
    sq += d * d;
  }
  if (r == HETINV_SUCCESS) {
    double m = sum / replicates;
    out->loss_truth = truth_sum / replicates;
    out->loss_difference = m;
    out->loss_difference_se = sqrt(fmax(sq / replicates - m * m, 0.0) * replicates / (replicates - 1.0) / replicates);
    out->loss_replicates = replicates;
  }
  return r;
}

hetinv_result_t fit_check_compare(hetinv_context_t *ctx, const recon_scene_t *sc, const hetinv_measurements_t *set,
                                  const hetinv_medium_t *truth, const hetinv_medium_t *rec, int64_t photons,
                                  int32_t replicates, fit_check_t *out) {
  *out = (fit_check_t){0};
  double t0 = recon_now();
  hetinv_estimator_t *est = NULL;
  size_t n = hetinv_measurements_value_count(set);
  double *buf = malloc(6 * (n ? n : 1) * sizeof *buf);
  hetinv_result_t r = buf ? HETINV_SUCCESS : HETINV_ERROR_OUT_OF_MEMORY;
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &est);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, (double)photons);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, FIT_CHECK_STREAM);
  double *it = buf, *st = buf + n, *ir = buf + 2 * n, *sr = buf + 3 * n, *pt = buf + 4 * n, *pr = buf + 5 * n;
  if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, truth, set, it, st, NULL, n);
  if (r == HETINV_SUCCESS) r = hetinv_estimator_render(est, rec, set, ir, sr, NULL, n);
  if (r == HETINV_SUCCESS) {
    misfit(set, it, st, &out->truth, &out->truth_se, pt);
    misfit(set, ir, sr, &out->recovery, &out->recovery_se, pr);
    /* The difference's error without the two renders' covariance, which
     * is positive (they share photons): an upper bound. */
    const double *w = hetinv_measurements_weights(set), *se = hetinv_measurements_std_errors(set);
    const uint8_t *mask = hetinv_measurements_mask(set);
    double var = 0.0;
    for (size_t i = 0; i < n; ++i) {
      if (!mask[i] || !(w[i] > 0.0)) continue;
      var += pt[i] + pr[i];
      out->expected += w[i] * se[i] * se[i];
      ++out->values;
    }
    out->difference_se = sqrt(var);
    find_worst(set, pt, pr, it, st, ir, sr, var, out);
    tails(set, it, out);
    r = loss_pairs(est, sc, truth, rec, set, replicates, it, st, ir, sr, out);
  }
  out->seconds = recon_now() - t0;
  free(buf);
  hetinv_estimator_destroy(&est);
  return r;
}

int fit_check_run(const recon_scene_t *sc, int64_t threads, int64_t photons, int32_t replicates,
                  fit_check_t *out, char *msg, size_t msg_size) {
  *out = (fit_check_t){0};
  double t0 = recon_now();
  stored_cell_t cell;
  if (stored_cell_open(sc, threads, &cell, msg, msg_size) != 0) return -1;
  hetinv_result_t r = fit_check_compare(cell.ctx, sc, cell.im.set, cell.truth, cell.recovery, photons, replicates, out);
  if (r != HETINV_SUCCESS) snprintf(msg, msg_size, "%s: %s", sc->name, hetinv_context_last_error_message(cell.ctx));
  out->seconds = recon_now() - t0; /* the data's simulation included */
  stored_cell_close(&cell);
  return r == HETINV_SUCCESS ? 0 : -1;
}

const char *fit_check_verdict(double d, double se) {
  return fabs(d) < 2.0 * se ? "no difference" : d < 0.0 ? "data" : "optimizer";
}

int fit_check_store(const recon_scene_t *sc, int64_t photons, const fit_check_t *f) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/fit_check.csv", sc->output);
  FILE *out = text_file_begin(path, tmp, sizeof tmp);
  if (out == NULL) return -1;
  double d = f->recovery - f->truth;
  fprintf(out, "quantity,truth,recovery_minus_truth,std_error,verdict\n");
  fprintf(out, "misfit,%.9g,%.9g,%.3g,%s\n", f->truth, d, f->difference_se, fit_check_verdict(d, f->difference_se));
  fprintf(out, "misfit_without_ten,,%.9g,%.3g,%s\n", f->trimmed_difference, f->trimmed_se,
          fit_check_verdict(f->trimmed_difference, f->trimmed_se));
  fprintf(out, "run_loss,%.9g,%.9g,%.3g,%s\n", f->loss_truth, f->loss_difference, f->loss_difference_se,
          fit_check_verdict(f->loss_difference, f->loss_difference_se));
  fprintf(out, "photons,%lld\nreplicates,%d\nloss_clip,%.9g\nseconds,%.3f\n", (long long)photons,
          (int)f->loss_replicates, sc->loss_clip, f->seconds);
  return text_file_commit(out, tmp, path);
}

/* "no difference at this precision", or which of the two fits the data
 * better and so what limits the recovery. */
static const char *verdict_words(double d, double se) {
  return fabs(d) < 2.0 * se ? "no difference at this precision"
         : d < 0.0          ? "the data prefer the recovery: what limits it is the data"
                            : "the truth fits better: what limits it is the optimizer";
}

void fit_check_print(const recon_scene_t *sc, int64_t photons, const fit_check_t *f) {
  double diff = f->recovery - f->truth;
  printf("%s: misfit at the truth %.6g +- %.2g (expected %.6g from the data's noise, %zu values), "
         "at the recovery %.6g +- %.2g; recovery - truth %+.6g +- %.2g: %s (%lld photons per source, %.0f s)\n",
         sc->name, f->truth, f->truth_se, f->expected, f->values, f->recovery, f->recovery_se, diff,
         f->difference_se, verdict_words(diff, f->difference_se), (long long)photons, f->seconds);
  printf("  the ten values with the largest shares of that error hold %.0f %% of its variance; the largest "
         "(%.0f %%): row %d (%s), data %.3g +- %.2g, the truth's render %.3g +- %.2g\n",
         100.0 * f->top10_share, 100.0 * f->worst.share, (int)f->worst.row,
         f->worst.bins ? "pathlength bins" : "steady", f->worst.data, f->worst.data_se, f->worst.render,
         f->worst.render_se);
  printf("  the truth's render against the data: %zu / %zu / %zu of %zu values beyond %g / %g / %g standard "
         "errors; those beyond %g hold %.1f %% of the truth's sum of squares\n",
         f->beyond[0], f->beyond[1], f->beyond[2], f->values, FIT_CHECK_TAILS[0], FIT_CHECK_TAILS[1],
         FIT_CHECK_TAILS[2], FIT_CHECK_TAILS[1], 100.0 * f->beyond10_share);
  double t = f->trimmed_difference, tse = f->trimmed_se;
  printf("  without those ten values: recovery - truth %+.6g +- %.2g: %s\n", t, tse,
         fabs(t) < 2.0 * tse ? "no difference at this precision"
         : t < 0.0          ? "the data prefer the recovery"
                            : "the truth fits better");
  double d = f->loss_difference, dse = f->loss_difference_se;
  printf("  the run's loss (%s), %d pairs of renders: at the truth %.6g, recovery - truth %+.6g +- %.2g: %s\n",
         sc->loss_clip > 0.0 ? "Huber's" : "least squares", (int)f->loss_replicates, f->loss_truth, d, dse,
         verdict_words(d, dse));
  fflush(stdout);
}
