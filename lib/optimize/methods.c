/* The descent methods. Each works in scaled coordinates (entry k moves in
 * units of its scale s_k) and ends with the projection onto the box.
 *
 * With HETINV_COORDINATES_REDUCED a cell whose σs and g are both free moves
 * in (σs' = σs(1 − g), g) instead of (σs, g). Steady light sees mostly σs'
 * (similarity, the paper's Lemma 1), so in native coordinates the loss has a
 * long narrow valley along σs(1 − g) = const that a per-entry step (every
 * method here) crosses slowly; in reduced coordinates the valley lies along
 * the g axis, where a per-entry step adapts to it.
 *
 * With HETINV_COORDINATES_LOG an entry with a positive bounded box moves in
 * ln π at the scale ln(hi/lo): once the gradient is mostly noise, ADADELTA's
 * steps settle at about ε times the scale, which natively is the box's
 * width, the same absolute size for a value at the box's floor as at its
 * top, so values near the floor wander furthest in relative terms (Fig. 4's
 * worst voxels at full size). In ln π the wander is relative.
 *
 * HETINV_COORDINATES_LOG_REDUCED is both: a pair moves in (ln σs', g), every
 * other entry as under HETINV_COORDINATES_LOG.
 *
 * HETINV_COORDINATES_LOG_MEAN_RATIO moves a cell's σa and σs as
 * (p, q) = ((ln σa + ln σs)/2, (ln σa − ln σs)/2): steady light's valley
 * between the two (the product is what diffusion sees) lies along q. */
#include <math.h>

#include "optimize/optimizer_internal.h"

typedef struct method {
  int id;
  double gamma, eps, rate, b1, b2, c1, c2;
} method_t;

/* The method's move of entry i for gradient g at scale s (the entry's, or
 * its log coordinate's), updating its accumulators. */
static double delta_at(const method_t *m, hetinv_optimizer_t *opt, size_t i, double g, double s) {
  double d = 0.0;
  double *a1 = &opt->acc1[i], *a2 = &opt->acc2[i];
  switch (m->id) {
    case HETINV_METHOD_ADADELTA: {
      /* Zeiler 2012, Algorithm 1: RMS[δ]_{t-1} / RMS[g]_t · g. An entry
       * no path has reached yet (E[g²] = 0) does not move. */
      *a1 = m->gamma * *a1 + (1.0 - m->gamma) * g * g;
      double eps_k = (m->eps * s) * (m->eps * s);
      d = *a1 > 0.0 ? sqrt(*a2 + eps_k) / sqrt(*a1) * g : 0.0;
      *a2 = m->gamma * *a2 + (1.0 - m->gamma) * d * d;
      break;
    }
    case HETINV_METHOD_SGD:
      d = m->rate * s * s * g;
      break;
    case HETINV_METHOD_ADAGRAD:
      *a1 += g * g;
      d = *a1 > 0.0 ? m->rate * s * g / sqrt(*a1) : 0.0;
      break;
    default: /* HETINV_METHOD_ADAM */
      *a1 = m->b1 * *a1 + (1.0 - m->b1) * g;
      *a2 = m->b2 * *a2 + (1.0 - m->b2) * g * g;
      d = *a2 > 0.0 ? m->rate * s * (*a1 / m->c1) / sqrt(*a2 / m->c2) : 0.0;
      break;
  }
  return d;
}

static double delta(const method_t *m, hetinv_optimizer_t *opt, size_t i, double g) {
  return delta_at(m, opt, i, g, opt->scale[i]);
}

/* HETINV_COORDINATES_LOG: entry i in u = ln π, whose gradient is π·g and
 * whose scale is ln(hi/lo); 0 if the entry's box does not allow it. */
static double log_scale(const hetinv_optimizer_t *opt, size_t i) {
  if (!hv_entry_log_box(opt, i)) return 0.0;
  double ratio = opt->hi_k[i] / opt->lo_k[i];
  return isfinite(ratio) ? log(ratio) : log(opt->hi_k[i]) - log(opt->lo_k[i]); /* e.g. [1e-300, 1e50] */
}

static double clamp(double x, double lo, double hi) { return fmin(fmax(x, lo), hi); }

/* One step of σs entry i and its cell's g entry j in (σs', g): by the chain
 * rule ∂L/∂σs' = ∂L/∂σs / (1 − g) and ∂L/∂g|σs' = ∂L/∂g + ∂L/∂σs · σs / (1 − g).
 * The new point is projected onto the native box (g first, then σs). */
static void reduced_step(const method_t *m, hetinv_optimizer_t *opt, size_t i, size_t j,
                         double *di, double *dj) {
  double s = opt->pi[i], g = opt->pi[j], q = 1.0 - g;
  double gr = opt->grad[i] / q, gg = opt->grad[j] + opt->grad[i] * s / q;
  double dr = delta(m, opt, i, gr), dg = delta(m, opt, j, gg);
  double g_new = clamp(g - dg, opt->move_lo_k[j], opt->move_hi_k[j]);
  double s_new = clamp((s * q - dr) / (1.0 - g_new), opt->move_lo_k[i], opt->move_hi_k[i]);
  *di = s - s_new;
  *dj = g - g_new;
  opt->pi[i] = s_new;
  opt->pi[j] = g_new;
}

/* reduced_step in (u = ln σs', g) where σs's box is positive and bounded
 * (else reduced_step): σs = e^u / (1 − g), so ∂L/∂u = ∂L/∂σs · σs and
 * ∂L/∂g|u = ∂L/∂g + ∂L/∂σs · σs / (1 − g), the same as in (σs', g); u's
 * scale su is log_scale of σs's entry. Returns u's move (for the step's
 * RMS, in units of su) through *du_scaled. */
static void log_reduced_step(const method_t *m, hetinv_optimizer_t *opt, size_t i, size_t j, double su,
                             double *du_scaled, double *dj) {
  double s = opt->pi[i], g = opt->pi[j], q = 1.0 - g;
  double gu = opt->grad[i] * s, gg = opt->grad[j] + opt->grad[i] * s / q;
  double du = delta_at(m, opt, i, gu, su), dg = delta(m, opt, j, gg);
  double g_new = clamp(g - dg, opt->move_lo_k[j], opt->move_hi_k[j]);
  opt->pi[i] = clamp(s * q * exp(-du) / (1.0 - g_new), opt->move_lo_k[i], opt->move_hi_k[i]);
  opt->pi[j] = g_new;
  *du_scaled = du / su;
  *dj = g - g_new;
}

/* One step of σa entry i and its cell's σs entry j in (p, q) (the header):
 * ln σa = p + q, ln σs = p − q, so ∂L/∂p = σa·∂L/∂σa + σs·∂L/∂σs and
 * ∂L/∂q = σa·∂L/∂σa − σs·∂L/∂σs; both at scale s. Returns the two moves
 * (in units of s) through *dp_scaled, *dq_scaled. */
static void mean_ratio_step(const method_t *m, hetinv_optimizer_t *opt, size_t i, size_t j, double s,
                            double *dp_scaled, double *dq_scaled) {
  double a = opt->pi[i], b = opt->pi[j];
  double ga = a * opt->grad[i], gb = b * opt->grad[j];
  double dp = delta_at(m, opt, i, ga + gb, s), dq = delta_at(m, opt, j, ga - gb, s);
  opt->pi[i] = clamp(a * exp(-dp - dq), opt->move_lo_k[i], opt->move_hi_k[i]);
  opt->pi[j] = clamp(b * exp(-dp + dq), opt->move_lo_k[j], opt->move_hi_k[j]);
  *dp_scaled = dp / s;
  *dq_scaled = dq / s;
}

double hv_stage_epsilon(const hetinv_optimizer_t *opt) {
  const double end = opt->param[HETINV_OPTIMIZER_EPSILON];
  const hv_stage_t *st = &opt->stages[opt->stage];
  if (st->settle_epsilon > 0.0 && opt->stage_iteration >= hv_stage_settle_from(st)) return st->settle_epsilon;
  if (st->epsilon_start == 0.0) return end;
  /* Linear from epsilon_start at the stage's first step to the tunable at
   * its middle; the second half, which the result averages, at the tunable. */
  double half = 0.5 * (double)st->iterations, t = (double)opt->stage_iteration;
  double f = half > 0.0 && t < half ? 1.0 - t / half : 0.0;
  return end + (st->epsilon_start - end) * f;
}

double hv_method_step(hetinv_optimizer_t *opt, const uint8_t *frozen, double epsilon) {
  const double *par = opt->param;
  double b1 = par[HETINV_OPTIMIZER_BETA1], b2 = par[HETINV_OPTIMIZER_BETA2];
  /* Adam's bias corrections, for the stage's iteration t = 1, 2, ... */
  double t = (double)(opt->stage_iteration + 1);
  /* A stage's ε schedule (epsilon_start, settling) scales the other
   * methods' step size by the same factor as ADADELTA's ε: exactly 1 where
   * the stage runs at the tunable. */
  double rate = par[HETINV_OPTIMIZER_LEARNING_RATE] * (epsilon / par[HETINV_OPTIMIZER_EPSILON]);
  method_t m = {(int)par[HETINV_OPTIMIZER_METHOD], par[HETINV_OPTIMIZER_DECAY], epsilon, rate, b1, b2,
                1.0 - pow(b1, t), 1.0 - pow(b2, t)};
  int coordinates = (int)par[HETINV_OPTIMIZER_COORDINATES];
  bool mean_ratio = coordinates == HETINV_COORDINATES_LOG_MEAN_RATIO;
  bool reduced = coordinates == HETINV_COORDINATES_REDUCED || coordinates == HETINV_COORDINATES_LOG_REDUCED;
  bool logs = coordinates == HETINV_COORDINATES_LOG || coordinates == HETINV_COORDINATES_LOG_REDUCED || mean_ratio;
  bool paired = reduced || mean_ratio;
  double sq = 0.0;
  size_t moved = 0;
  for (size_t i = 0; i < opt->k; ++i) {
    /* A pair steps when its first entry comes (pair_cells pairs only free
     * entries, and for mean-ratio steps only boxes that allow logs). */
    if ((frozen && frozen[i]) || (paired && opt->pair_first[i] >= 0)) continue;
    int64_t j = paired ? opt->pair_second[i] : -1;
    double d = 0.0, s = logs ? log_scale(opt, i) : 0.0;
    if (mean_ratio && j >= 0) {
      double dp = 0.0, dq = 0.0, sp = 0.5 * (s + log_scale(opt, (size_t)j));
      mean_ratio_step(&m, opt, i, (size_t)j, sp, &dp, &dq);
      sq += dp * dp + dq * dq;
      moved += 2;
      continue;
    }
    if (j >= 0 && s > 0.0) {
      double du = 0.0, dj = 0.0;
      log_reduced_step(&m, opt, i, (size_t)j, s, &du, &dj);
      sq += du * du + (dj / opt->scale[j]) * (dj / opt->scale[j]);
      moved += 2;
      continue;
    } else if (j >= 0) {
      double dj = 0.0;
      reduced_step(&m, opt, i, (size_t)j, &d, &dj);
      sq += (dj / opt->scale[j]) * (dj / opt->scale[j]);
      ++moved;
    } else if (s > 0.0) {
      double pi = opt->pi[i];
      double du = delta_at(&m, opt, i, pi * opt->grad[i], s);
      opt->pi[i] = clamp(pi * exp(-du), opt->move_lo_k[i], opt->move_hi_k[i]);
      sq += (du / s) * (du / s);
      ++moved;
      continue;
    } else {
      d = delta(&m, opt, i, opt->grad[i]);
      opt->pi[i] = clamp(opt->pi[i] - d, opt->move_lo_k[i], opt->move_hi_k[i]);
    }
    sq += (d / opt->scale[i]) * (d / opt->scale[i]);
    ++moved;
  }
  return moved ? sqrt(sq / (double)moved) : 0.0;
}
