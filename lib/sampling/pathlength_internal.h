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
  /* Instrument response (hetinv_pathlength_create_bins_irf): taps > 0
   * non-zero samples, weights summing to 1 at pathlength offsets. taps = 0:
   * none, exactly the bare windows. */
  int32_t taps;
  double *tap_offset, *tap_weight;
  double late; /* max over taps of -offset (0 without): a bin collects τ < centre + reach + late */
};

/* Calls BODY with `bin` and `weight` = W_τ(tau) for every bin whose window
 * reaches tau (the one bin 0 for steady state). With an instrument
 * response, for every tap j the bins reaching tau + offset_j, with weight
 * W_τ(tau + offset_j)·h_j; without one, one implicit tap of offset 0 and
 * weight 1, which changes no bit (tau is used as it is, W·1.0 = W). */
#define HV_FOR_EACH_BIN(pl, tau, BODY) \
  do { \
    if ((pl)->steady) { \
      int32_t bin = 0; \
      double weight = 1.0; \
      BODY \
      break; \
    } \
    int32_t taps_ = (pl)->taps > 0 ? (pl)->taps : 1; \
    for (int32_t t_ = 0; t_ < taps_; ++t_) { \
      double tau_ = (pl)->taps > 0 ? (tau) + (pl)->tap_offset[t_] : (tau); \
      double h_ = (pl)->taps > 0 ? (pl)->tap_weight[t_] : 1.0; \
      /* First sorted centre > tau_ - reach, by bisection. */ \
      double lo_c_ = tau_ - (pl)->reach; \
      int32_t lo_ = 0, hi_ = (pl)->count; \
      while (lo_ < hi_) { \
        int32_t mid_ = lo_ + (hi_ - lo_) / 2; \
        if ((pl)->sorted[mid_] > lo_c_) hi_ = mid_; else lo_ = mid_ + 1; \
      } \
      for (int32_t i_ = lo_; i_ < (pl)->count; ++i_) { \
        /* box bin [c - w/2, c + w/2) holds tau_ iff tau_ - c in [-w/2, w/2); \
         * the bisection already gave tau_ - c < reach */ \
        double x_ = tau_ - (pl)->sorted[i_]; \
        if (x_ < -(pl)->reach || ((pl)->window != HETINV_WINDOW_BOX && x_ <= -(pl)->reach)) break; \
        int32_t bin = (pl)->bin_of[i_]; \
        double z_ = x_ / (pl)->width; \
        double weight = ((pl)->window == HETINV_WINDOW_BOX ? 1.0 : exp(-0.5 * z_ * z_)) * h_; \
        BODY \
      } \
    } \
  } while (0)

/* Adds value·W_τ(tau) of every bin to dst[bin·stride]. */
static inline void hv_pathlength_splat(const hetinv_pathlength_t *pl, double tau, double value,
                                       double *dst, int32_t stride) {
  HV_FOR_EACH_BIN(pl, tau, { dst[(size_t)bin * (size_t)stride] += value * weight; });
}

/* Σ_bins W_τ(tau)·src[bin·stride]: the splat's weight under a cotangent. */
static inline double hv_pathlength_dot(const hetinv_pathlength_t *pl, double tau,
                                       const double *src, int32_t stride) {
  double sum = 0.0;
  HV_FOR_EACH_BIN(pl, tau, { sum += weight * src[(size_t)bin * (size_t)stride]; });
  return sum;
}

#endif
