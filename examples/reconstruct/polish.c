/* Gauss–Newton polish of a finished recovery (polish.h). */
#include "polish.h"

#include <errno.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "stored_cell.h"

/* Streams no optimizer iteration, acquisition, fit or gradient check uses:
 * a loss gradient takes two, F̂'s replicates two each from FISHER. */
#define POLISH_STREAM 62000
#define POLISH_FISHER_STREAM 64000

/* Lower Cholesky factor of the n×n row-major a, in place; 0, or -1 if a
 * pivot is not positive (a not positive definite). */
static int cholesky(double *a, size_t n) {
  for (size_t j = 0; j < n; ++j) {
    double *rj = a + j * n;
    double d = rj[j];
    for (size_t m = 0; m < j; ++m) d -= rj[m] * rj[m];
    if (!(d > 0.0)) return -1;
    d = sqrt(d);
    rj[j] = d;
    for (size_t i = j + 1; i < n; ++i) {
      double *ri = a + i * n, s = ri[j];
      for (size_t m = 0; m < j; ++m) s -= ri[m] * rj[m];
      ri[j] = s / d;
    }
  }
  return 0;
}

/* Solves L Lᵀ x = b in place. */
static void cholesky_solve(const double *l, size_t n, double *x) {
  for (size_t i = 0; i < n; ++i) {
    double s = x[i];
    for (size_t m = 0; m < i; ++m) s -= l[i * n + m] * x[m];
    x[i] = s / l[i * n + i];
  }
  for (size_t i = n; i-- > 0;) {
    double s = x[i];
    for (size_t m = i + 1; m < n; ++m) s -= l[m * n + i] * x[m];
    x[i] = s / l[i * n + i];
  }
}

/* The smoothness prior of the optimizer (HETINV_OPTIMIZER_SMOOTHNESS, its
 * definition in lib/optimize/smoothness.c) on the map's cells: adds its
 * gradient to grad and, with h non-NULL, its Hessian to h; returns its value. */
static double prior_add(const hetinv_param_map_t *map, double lambda, const double *scale, const double *pi,
                        size_t k, double *grad, double *h) {
  if (!(lambda > 0.0)) return 0.0;
  int32_t dims[3] = {1, 1, 1};
  hetinv_param_map_get_dims(map, dims);
  size_t cells = (size_t)dims[0] * (size_t)dims[1] * (size_t)dims[2];
  size_t stride[3] = {1, (size_t)dims[0], (size_t)dims[0] * (size_t)dims[1]};
  double value = 0.0;
  for (size_t b = 0; b < k / cells; ++b) {
    for (int a = 0; a < 3; ++a) {
      if (dims[a] < 2) continue;
      double w = lambda * (double)dims[a] * (double)dims[a] / (double)cells;
      for (size_t c = 0; c < cells; ++c) {
        if ((int32_t)(c / stride[a] % (size_t)dims[a]) + 1 == dims[a]) continue;
        size_t i = b * cells + c, j = i + stride[a];
        double d = pi[i] / scale[i] - pi[j] / scale[j];
        value += w * d * d;
        grad[i] += 2.0 * w * d / scale[i];
        grad[j] -= 2.0 * w * d / scale[j];
        if (h != NULL) {
          h[i * k + i] += 2.0 * w / (scale[i] * scale[i]);
          h[j * k + j] += 2.0 * w / (scale[j] * scale[j]);
          h[i * k + j] -= 2.0 * w / (scale[i] * scale[j]);
          h[j * k + i] -= 2.0 * w / (scale[i] * scale[j]);
        }
      }
    }
  }
  return value;
}

/* Mean loss gradient over `replicates` independent renders at `medium`. */
static hetinv_result_t mean_gradient(hetinv_estimator_t *est, const hetinv_medium_t *medium,
                                     const hetinv_measurements_t *set, const hetinv_param_map_t *map,
                                     int32_t replicates, int32_t first, double *g, double *tmp, size_t k,
                                     double *loss, double *loss_se) {
  hetinv_result_t r = HETINV_SUCCESS;
  double sum = 0.0, sq = 0.0;
  for (size_t i = 0; i < k; ++i) g[i] = 0.0;
  for (int32_t j = 0; r == HETINV_SUCCESS && j < replicates; ++j) {
    double l = 0.0;
    r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, POLISH_STREAM + 2 * (first + j));
    if (r == HETINV_SUCCESS) r = hetinv_estimator_loss_gradient(est, medium, set, map, &l, NULL, tmp, k);
    for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) g[i] += tmp[i] / replicates;
    sum += l;
    sq += l * l;
  }
  double m = sum / replicates;
  *loss = m;
  *loss_se = sqrt(fmax(sq / replicates - m * m, 0.0) / (replicates - 1.0));
  return r;
}

/* F̂ is the costly part (minutes at the paper's size) and depends only on
 * the stored recovery and its photons: it is kept beside the cell in
 * polish_fisher.bin (a header line naming what it was taken with, then
 * k·k doubles in this machine's byte order) and read back by a later
 * polish of the same recovery (its entries' hash) with the same settings. */
static void fisher_header(char *line, size_t size, const double *pi, size_t k, double photons, int32_t replicates) {
  /* FNV-1a 64 of the recovery's entries: a polished copy polished again
   * must not reuse the matrix of the recovery it replaced. */
  uint64_t hash = recon_fnv1a(RECON_FNV_OFFSET, pi, k * sizeof *pi);
  snprintf(line, size, "hetinv polish Fisher matrix: k=%zu photons=%.0f replicates=%d stream=%d recovery=%016llx\n", k,
           photons, (int)replicates, POLISH_FISHER_STREAM, (unsigned long long)hash);
}

static int fisher_load(const recon_scene_t *sc, const char *header, double *f, size_t k) {
  char path[1200], line[256];
  snprintf(path, sizeof path, "%s/polish_fisher.bin", sc->output);
  FILE *in = fopen(path, "rb");
  if (in == NULL) return -1;
  bool same = fgets(line, sizeof line, in) != NULL && strcmp(line, header) == 0; /* else another recovery's */
  bool ok = same && fread(f, sizeof *f, k * k, in) == k * k && fgetc(in) == EOF;
  fclose(in);
  /* Every entry of an estimated Fisher matrix is finite, its diagonal >= 0:
   * a cache that is not is damaged, and recomputed rather than trusted. */
  for (size_t i = 0; ok && i < k * k; ++i) ok = isfinite(f[i]) && (i % (k + 1) != 0 || f[i] >= 0.0);
  if (same && !ok) fprintf(stderr, "%s: damaged; computing the matrix again\n", path);
  return ok ? 0 : -1;
}

/* Best effort: a polish without its cache is only slower. */
static void fisher_store(const recon_scene_t *sc, const char *header, const double *f, size_t k) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/polish_fisher.bin", sc->output);
  snprintf(tmp, sizeof tmp, "%s.tmp", path);
  FILE *out = fopen(tmp, "wb");
  if (out == NULL) return;
  int ok = fputs(header, out) >= 0 && fwrite(f, sizeof *f, k * k, out) == k * k;
  ok = fclose(out) == 0 && ok;
  if (!ok || rename(tmp, path) != 0) remove(tmp);
}

/* The Gauss–Newton matrix 2F̂ + H_prior at the start (row-major k×k). */
static hetinv_result_t curvature(hetinv_estimator_t *est, const recon_scene_t *sc, const hetinv_medium_t *rec,
                                 const hetinv_measurements_t *set, const hetinv_param_map_t *map,
                                 const polish_options_t *o, const double *scale, const double *pi, size_t k,
                                 double *h) {
  size_t n = hetinv_measurements_value_count(set);
  double *var = malloc((n + k) * sizeof *var);
  if (var == NULL) return HETINV_ERROR_OUT_OF_MEMORY;
  double *scratch = var + n;
  const double *w = hetinv_measurements_weights(set);
  /* The loss's weights as the data's 1/σ²: a value of weight 0 counts for nothing. */
  for (size_t i = 0; i < n; ++i) var[i] = w[i] > 0.0 ? 1.0 / w[i] : 1e300;
  double photons = 0.0;
  hetinv_result_t r = hetinv_estimator_get_param(est, HETINV_ESTIMATOR_PHOTONS, &photons);
  double fisher_photons = o->fisher_photons > 0 ? (double)o->fisher_photons : photons;
  char header[256];
  fisher_header(header, sizeof header, pi, k, fisher_photons, o->fisher_replicates);
  if (r == HETINV_SUCCESS && fisher_load(sc, header, h, k) != 0) {
    r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_STREAM, POLISH_FISHER_STREAM);
    if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, fisher_photons);
    if (r == HETINV_SUCCESS) r = hetinv_estimator_fisher(est, rec, set, var, n, map, o->fisher_replicates, h, NULL, k);
    if (r == HETINV_SUCCESS) r = hetinv_estimator_set_param(est, HETINV_ESTIMATOR_PHOTONS, photons);
    if (r == HETINV_SUCCESS) fisher_store(sc, header, h, k);
  }
  for (size_t i = 0; r == HETINV_SUCCESS && i < k * k; ++i) h[i] *= 2.0;
  if (r == HETINV_SUCCESS) prior_add(map, sc->smoothness, scale, pi, k, scratch, h);
  free(var);
  return r;
}

/* δ ≈ −(H + μ·diag H)⁻¹ g by conjugate gradients preconditioned with the
 * diagonal, from δ = 0, stopped after `iterations` or where the residual
 * falls below 1e-8 of g's, or before a direction of curvature ≤ 0: F̂'s
 * noise gives it a few eigenvalues of either sign near 0, and CG meets
 * the strongly determined directions first, so a truncated solve moves
 * those fully and leaves the noise's alone (Steihaug's rule without the
 * move to the boundary). *used receives the iterations taken, *negative
 * 1 if a direction of curvature ≤ 0 stopped it. */
static void cg_step(const double *h, const double *g, size_t k, double mu, int32_t iterations, double *work,
                    double *delta, int32_t *used, int *negative) {
  double *res = work, *z = work + k, *p = work + 2 * k, *hp = work + 3 * k;
  double rz = 0.0, g2 = 0.0;
  *used = 0;
  *negative = 0;
  for (size_t i = 0; i < k; ++i) {
    delta[i] = 0.0;
    res[i] = -g[i];
    z[i] = res[i] / ((1.0 + mu) * fabs(h[i * k + i]));
    p[i] = z[i];
    rz += res[i] * z[i];
    g2 += g[i] * g[i];
  }
  for (int32_t it = 0; it < iterations; ++it) {
    double php = 0.0;
    for (size_t i = 0; i < k; ++i) {
      double v = mu * fabs(h[i * k + i]) * p[i];
      for (size_t j = 0; j < k; ++j) v += h[i * k + j] * p[j];
      hp[i] = v;
      php += p[i] * v;
    }
    if (!(php > 0.0)) {
      *negative = 1;
      return;
    }
    double alpha = rz / php, rz_next = 0.0, r2 = 0.0;
    for (size_t i = 0; i < k; ++i) {
      delta[i] += alpha * p[i];
      res[i] -= alpha * hp[i];
      z[i] = res[i] / ((1.0 + mu) * fabs(h[i * k + i]));
      rz_next += res[i] * z[i];
      r2 += res[i] * res[i];
    }
    *used = it + 1;
    if (r2 <= 1e-16 * g2) return;
    for (size_t i = 0; i < k; ++i) p[i] = z[i] + rz_next / rz * p[i];
    rz = rz_next;
  }
}

/* δ = −(H + μ·diag H)⁻¹ g, μ raised ×4 from `damping` until the matrix
 * factors; a the k×k work matrix. Returns the μ used, or NaN. */
static double damped_step(const double *h, const double *g, size_t k, double damping, double *a, double *delta) {
  for (double mu = damping; mu < 1e6; mu *= 4.0) {
    memcpy(a, h, k * k * sizeof *a);
    for (size_t i = 0; i < k; ++i) a[i * k + i] += mu * fabs(h[i * k + i]);
    if (cholesky(a, k) != 0) continue;
    for (size_t i = 0; i < k; ++i) delta[i] = -g[i];
    cholesky_solve(a, k, delta);
    return mu;
  }
  return NAN;
}

/* ‖(H + μ·diag H)δ + g‖ ÷ ‖g‖: near 0 for a solve that succeeded (a
 * check on the solver); a truncated CG leaves part of g. */
static double solve_residual(const double *h, const double *g, const double *delta, size_t k, double mu) {
  double r2 = 0.0, g2 = 0.0;
  for (size_t i = 0; i < k; ++i) {
    double v = g[i] + mu * fabs(h[i * k + i]) * delta[i];
    for (size_t j = 0; j < k; ++j) v += h[i * k + j] * delta[j];
    r2 += v * v;
    g2 += g[i] * g[i];
  }
  return g2 > 0.0 ? sqrt(r2 / g2) : 0.0;
}

static int store(const recon_scene_t *sc, const polish_report_t *rep) {
  char path[1200], tmp[1220];
  snprintf(path, sizeof path, "%s/polish.csv", sc->output);
  FILE *out = text_file_begin(path, tmp, sizeof tmp);
  if (out == NULL) return -1;
  fprintf(out, "step,loss,loss_se,prior,damping,cg_iterations,cg_negative_curvature,solve_residual,"
               "predicted_decrease,step_rms,clipped,sigma_a_mean,sigma_a_max,sigma_s_mean,sigma_s_max,g_mean,g_max\n");
  const recon_errors_t *e = &rep->start;
  fprintf(out, "0,,,,,,,,,,,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", e->mean[0], e->max[0], e->mean[1], e->max[1], e->mean[2],
          e->max[2]);
  for (int32_t s = 0; s < rep->count; ++s) {
    const polish_step_t *st = &rep->steps[s];
    e = &st->errors;
    fprintf(out, "%d,%.9g,%.3g,%.6g,%.4g,%d,%d,%.3g,%.6g,%.4g,%zu,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", (int)s + 1,
            st->loss, st->loss_se, st->prior, st->damping, (int)st->cg_iterations, st->cg_negative, st->residual, st->predicted,
            st->step_rms, st->clipped, e->mean[0], e->max[0], e->mean[1], e->max[1], e->mean[2], e->max[2]);
  }
  return text_file_commit(out, tmp, path);
}

static hetinv_result_t polish(hetinv_context_t *ctx, const recon_scene_t *sc, stored_cell_t *cell,
                              const polish_options_t *o, polish_report_t *rep, char *msg, size_t msg_size) {
  hetinv_param_map_t *map = NULL;
  hetinv_estimator_t *est = NULL;
  hetinv_medium_t *cur = NULL;
  double *buf = NULL;
  hetinv_result_t r = hetinv_param_map_create_identity(cell->recovery, HETINV_FREE_ALL, &map);
  size_t k = map ? hetinv_param_map_size(map) : 0;
  if (r == HETINV_SUCCESS && k > HETINV_FISHER_MAX_ENTRIES) {
    snprintf(msg, msg_size, "%s: --polish forms the dense Fisher matrix: %zu entries, at most %d", sc->name, k,
             HETINV_FISHER_MAX_ENTRIES);
    r = HETINV_ERROR_INVALID_ARGUMENT;
  }
  if (r == HETINV_SUCCESS) {
    buf = malloc((2 * k * k + 7 * k) * sizeof *buf);
    rep->steps = calloc((size_t)o->steps, sizeof *rep->steps);
    if (buf == NULL || rep->steps == NULL) r = HETINV_ERROR_OUT_OF_MEMORY;
  }
  double *h = buf, *a = buf + k * k, *pi = a + k * k, *g = pi + k, *tmp = g + k, *delta = tmp + k;
  double *scale = delta + k, *lo = scale + k, *hi = lo + k;
  if (r == HETINV_SUCCESS) r = hetinv_param_map_extract(map, cell->recovery, pi, k);
  for (size_t i = 0; r == HETINV_SUCCESS && i < k; ++i) {
    hetinv_param_t p = HETINV_PARAM_SIGMA_A;
    r = hetinv_param_map_entry(map, i, &p, NULL);
    lo[i] = sc->bounds_lo[p];
    hi[i] = sc->bounds_hi[p];
    scale[i] = isfinite(hi[i] - lo[i]) ? hi[i] - lo[i] : 1.0;
  }
  if (r == HETINV_SUCCESS) r = hetinv_estimator_create(ctx, &est);
  if (r == HETINV_SUCCESS) r = recon_estimator_configure(est, sc);
  double t0 = recon_now();
  if (r == HETINV_SUCCESS) r = curvature(est, sc, cell->recovery, cell->im.set, map, o, scale, pi, k, h);
  rep->fisher_seconds = recon_now() - t0;
  const hetinv_medium_t *at = cell->recovery;
  for (int32_t s = 0; r == HETINV_SUCCESS && s < o->steps; ++s) {
    polish_step_t *st = &rep->steps[s];
    r = mean_gradient(est, at, cell->im.set, map, o->replicates, s * o->replicates, g, tmp, k, &st->loss,
                      &st->loss_se);
    if (r != HETINV_SUCCESS) break;
    st->prior = prior_add(map, sc->smoothness, scale, pi, k, g, NULL);
    if (o->cg_iterations > 0) {
      st->damping = o->damping;
      cg_step(h, g, k, o->damping, o->cg_iterations, a, delta, &st->cg_iterations, &st->cg_negative);
    } else {
      st->damping = damped_step(h, g, k, o->damping, a, delta);
    }
    if (isnan(st->damping)) {
      snprintf(msg, msg_size, "%s: the Gauss-Newton matrix does not factor at any damping up to 1e6", sc->name);
      r = HETINV_ERROR_INVALID_STATE;
      break;
    }
    st->residual = solve_residual(h, g, delta, k, st->damping);
    double sq = 0.0;
    for (size_t i = 0; i < k; ++i) sq += (delta[i] / scale[i]) * (delta[i] / scale[i]);
    st->step_rms = sqrt(sq / (double)k);
    if (st->step_rms > o->max_step) {
      for (size_t i = 0; i < k; ++i) delta[i] *= o->max_step / st->step_rms;
    }
    double gd = 0.0, dhd = 0.0;
    for (size_t i = 0; i < k; ++i) {
      double hd = 0.0;
      for (size_t j = 0; j < k; ++j) hd += h[i * k + j] * delta[j];
      gd += g[i] * delta[i];
      dhd += delta[i] * hd;
      double next = fmin(fmax(pi[i] + delta[i], lo[i]), hi[i]);
      st->clipped += next != pi[i] + delta[i];
      pi[i] = next;
    }
    st->predicted = -(gd + 0.5 * dhd);
    hetinv_medium_destroy(&cur);
    r = hetinv_medium_clone(cell->recovery, &cur);
    if (r == HETINV_SUCCESS) r = hetinv_param_map_apply(map, pi, k, cur);
    if (r == HETINV_SUCCESS) r = hetinv_medium_commit(cur);
    if (r == HETINV_SUCCESS) {
      recon_errors(cell->truth, cur, &st->errors);
      rep->count = s + 1;
      at = cur;
    }
  }
  if (r == HETINV_SUCCESS && cur != NULL) {
    r = recon_write_outputs(ctx, sc, cell->truth, cur, &rep->steps[rep->count - 1].errors, msg, msg_size);
  }
  if (r != HETINV_SUCCESS && msg[0] == '\0') {
    snprintf(msg, msg_size, "%s: %s", sc->name, hetinv_context_last_error_message(ctx));
  }
  hetinv_medium_destroy(&cur);
  hetinv_estimator_destroy(&est);
  hetinv_param_map_destroy(&map);
  free(buf);
  return r;
}

int polish_run(const recon_scene_t *sc, int64_t threads, const polish_options_t *o, polish_report_t *out, char *msg,
               size_t msg_size) {
  *out = (polish_report_t){0};
  double t0 = recon_now();
  stored_cell_t cell;
  if (stored_cell_open(sc, threads, &cell, msg, msg_size) != 0) return -1;
  recon_errors(cell.truth, cell.recovery, &out->start);
  hetinv_result_t r = polish(cell.ctx, sc, &cell, o, out, msg, msg_size);
  out->seconds = recon_now() - t0;
  if (r == HETINV_SUCCESS && store(sc, out) != 0) {
    snprintf(msg, msg_size, "%s/polish.csv: %s", sc->output, strerror(errno));
    r = HETINV_ERROR_IO;
  }
  stored_cell_close(&cell);
  if (r != HETINV_SUCCESS) polish_release(out);
  return r == HETINV_SUCCESS ? 0 : -1;
}

static void print_errors(const char *what, const recon_errors_t *e) {
  printf("  %-8s sigma_a %.1f/%.1f %%, sigma_s %.1f/%.1f %%, g %.1f/%.1f %%\n", what, 100 * e->mean[0],
         100 * e->max[0], 100 * e->mean[1], 100 * e->max[1], 100 * e->mean[2], 100 * e->max[2]);
}

void polish_print(const recon_scene_t *sc, const polish_report_t *rep) {
  printf("%s: Gauss-Newton polish (%d steps, %.0f s, the Fisher matrix %.0f s); mean/max relative error:\n", sc->name,
         (int)rep->count, rep->seconds, rep->fisher_seconds);
  print_errors("stored", &rep->start);
  for (int32_t s = 0; s < rep->count; ++s) {
    const polish_step_t *st = &rep->steps[s];
    char what[32];
    snprintf(what, sizeof what, "step %d", (int)s + 1);
    print_errors(what, &st->errors);
    char solve[96];
    if (st->cg_iterations > 0 || st->cg_negative) {
      snprintf(solve, sizeof solve, "%d conjugate-gradient iterations%s", (int)st->cg_iterations,
               st->cg_negative ? ", stopped by curvature <= 0" : "");
    } else {
      snprintf(solve, sizeof solve, "Cholesky");
    }
    printf("           from loss %.6g +- %.2g (prior %.4g), damping %.3g, %s (residual %.2g), predicted decrease %.4g, "
           "step RMS %.3g of the box, %zu clipped\n",
           st->loss, st->loss_se, st->prior, st->damping, solve, st->residual, st->predicted, st->step_rms,
           st->clipped);
  }
  printf("  wrote %s/polish.csv and the polished recovery in place of the stored one\n", sc->output);
  fflush(stdout);
}

void polish_release(polish_report_t *rep) {
  free(rep->steps);
  rep->steps = NULL;
  rep->count = 0;
}
