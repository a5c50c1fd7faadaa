/* Pathlength sampling functions: which bins a pathlength falls in. */
#ifndef HV_PATHLENGTH_INTERNAL_H
#define HV_PATHLENGTH_INTERNAL_H

#include <math.h>
#include <stdbool.h>

#include "hetinv/sampling.h"

struct hetinv_pathlength {
  hetinv_context_t *ctx;
  bool steady;
  hetinv_window_t window;
  int32_t count;
  double width;
  double reach;      /* a bin counts only when |τ - centre| < reach (box: width/2) */
  double *sorted;    /* centres in increasing order */
  int32_t *bin_of;   /* bin index of each sorted centre */
};

/* Adds value·W_τ(tau) of every bin to dst[bin·stride]. */
static inline void hv_pathlength_splat(const hetinv_pathlength_t *pl, double tau, double value,
                                       double *dst, int32_t stride) {
  if (pl->steady) {
    dst[0] += value;
    return;
  }
  /* First sorted centre > tau - reach, by bisection. */
  double lo_c = tau - pl->reach;
  int32_t lo = 0, hi = pl->count;
  while (lo < hi) {
    int32_t mid = lo + (hi - lo) / 2;
    if (pl->sorted[mid] > lo_c) hi = mid; else lo = mid + 1;
  }
  for (int32_t i = lo; i < pl->count; ++i) {
    double x = tau - pl->sorted[i];
    if (pl->window == HETINV_WINDOW_BOX) {
      /* bin [c - w/2, c + w/2) holds τ iff τ - c ∈ [-w/2, w/2); the bisection
       * already gave τ - c < w/2. */
      if (x < -pl->reach) break;
      dst[(size_t)pl->bin_of[i] * (size_t)stride] += value;
    } else {
      if (x <= -pl->reach) break;
      double z = x / pl->width;
      dst[(size_t)pl->bin_of[i] * (size_t)stride] += value * exp(-0.5 * z * z);
    }
  }
}

#endif
