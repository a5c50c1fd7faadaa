/* The descent methods. Each works in scaled coordinates (entry k moves in
 * units of its scale s_k) and ends with the projection onto the box. */
#include <math.h>

#include "optimize/optimizer_internal.h"

double hv_method_step(hetinv_optimizer_t *opt, const uint8_t *frozen) {
  const double *par = opt->param;
  int method = (int)par[HETINV_OPTIMIZER_METHOD];
  double gamma = par[HETINV_OPTIMIZER_DECAY], eps = par[HETINV_OPTIMIZER_EPSILON];
  double rate = par[HETINV_OPTIMIZER_LEARNING_RATE];
  double b1 = par[HETINV_OPTIMIZER_BETA1], b2 = par[HETINV_OPTIMIZER_BETA2];
  /* Adam's bias corrections, for the stage's iteration t = 1, 2, ... */
  double t = (double)(opt->stage_iteration + 1);
  double c1 = 1.0 - pow(b1, t), c2 = 1.0 - pow(b2, t);
  double sq = 0.0;
  size_t moved = 0;
  for (size_t i = 0; i < opt->k; ++i) {
    if (frozen && frozen[i]) continue;
    double g = opt->grad[i], s = opt->scale[i], d = 0.0;
    double *a1 = &opt->acc1[i], *a2 = &opt->acc2[i];
    switch (method) {
      case HETINV_METHOD_ADADELTA: {
        /* Zeiler 2012, Algorithm 1: RMS[δ]_{t-1} / RMS[g]_t · g. An entry
         * no path has reached yet (E[g²] = 0) does not move. */
        *a1 = gamma * *a1 + (1.0 - gamma) * g * g;
        double eps_k = (eps * s) * (eps * s);
        d = *a1 > 0.0 ? sqrt(*a2 + eps_k) / sqrt(*a1) * g : 0.0;
        *a2 = gamma * *a2 + (1.0 - gamma) * d * d;
        break;
      }
      case HETINV_METHOD_SGD:
        d = rate * s * s * g;
        break;
      case HETINV_METHOD_ADAGRAD:
        *a1 += g * g;
        d = *a1 > 0.0 ? rate * s * g / sqrt(*a1) : 0.0;
        break;
      default: /* HETINV_METHOD_ADAM */
        *a1 = b1 * *a1 + (1.0 - b1) * g;
        *a2 = b2 * *a2 + (1.0 - b2) * g * g;
        d = *a2 > 0.0 ? rate * s * (*a1 / c1) / sqrt(*a2 / c2) : 0.0;
        break;
    }
    opt->pi[i] = fmin(fmax(opt->pi[i] - d, opt->lo_k[i]), opt->hi_k[i]);
    sq += (d / s) * (d / s);
    ++moved;
  }
  return moved ? sqrt(sq / (double)moved) : 0.0;
}
