/* One value's term of the loss of hetinv_estimator_loss_gradient(): least
 * squares, or Huber's with HETINV_ESTIMATOR_LOSS_CLIP. Shared by the plain
 * loss (gradient.c) and the loss at a fitted gain (gain.c). */
#ifndef HV_LOSS_TERM_H
#define HV_LOSS_TERM_H

#include <math.h>

/* Weight w ≥ 0, residual r, clip c in standard errors (0: none), scaled
 * by `below` where r < 0 and `above` where r > 0 (the set's clip scales).
 * Returns w·r² while √w·|r| ≤ c·s (or c = 0), 2·c·s·√w·|r| − (c·s)² beyond;
 * *slope gets the term's derivative in r, 2·w·r clipped at ±2·c·s·√w. */
static inline double hv_loss_term(double w, double r, double clip, double below, double above, double *slope) {
  double wr = w * r;
  if (clip > 0.0) {
    double c = clip * (r > 0.0 ? above : below);
    double bound = c * sqrt(w); /* |r|·√w > c  ⇔  |w·r| > c·√w */
    if (wr > bound || wr < -bound) {
      *slope = wr > 0.0 ? 2.0 * bound : -2.0 * bound;
      return 2.0 * bound * fabs(r) - c * c;
    }
  }
  *slope = 2.0 * wr;
  return wr * r;
}

#endif
