/* Phase functions behind a small interface (eval / sample / d log f / dg),
 * with Henyey–Greenstein as the first family. Everything is inline: the
 * photon loop calls these once per scattering vertex.
 *
 * Conventions: directions are unit vectors along which light travels, and
 * cosθ = dot(incoming, outgoing), so g > 0 is forward scattering. A phase
 * function is a density in solid angle, normalised to 1 over the sphere.
 * Every family is parametrised by the medium's per-voxel value g. */
#ifndef HV_PHASE_H
#define HV_PHASE_H

#include <assert.h>
#include <math.h>

#include "core/bits.h"

typedef enum hv_phase_family {
  HV_PHASE_HG, /* Henyey–Greenstein, g = mean cosine, -1 < g < 1 */
} hv_phase_family_t;

typedef struct hv_phase {
  hv_phase_family_t family;
  double g;
} hv_phase_t;

#define HV_INV_4PI 0.07957747154594766788 /* 1/(4π) */
#define HV_2PI 6.28318530717958647693

/* ---- Henyey–Greenstein -------------------------------------------------- */

/* f(cosθ) = (1-g²) / (4π (1+g²-2g cosθ)^{3/2}). */
static inline double hv_hg_eval(double g, double cos_theta) {
  double d = 1.0 + g * g - 2.0 * g * cos_theta;
  return (1.0 - g * g) * HV_INV_4PI / (d * sqrt(d));
}

/* ∂ log f / ∂g = -2g/(1-g²) + 3(cosθ - g)/(1+g²-2g cosθ). */
static inline double hv_hg_dlog_dg(double g, double cos_theta) {
  double d = 1.0 + g * g - 2.0 * g * cos_theta;
  return -2.0 * g / (1.0 - g * g) + 3.0 * (cos_theta - g) / d;
}

/* P(cos ≤ cosθ). The textbook (1-g²)/(2g)·[D^{-1/2} - 1/(1+g)] cancels as
 * g → 0; multiplied out it has no division by g. */
static inline double hv_hg_cdf(double g, double cos_theta) {
  double s = sqrt(1.0 + g * g - 2.0 * g * cos_theta);
  return (1.0 - g) * (1.0 + cos_theta) / (s * (1.0 + g + s));
}

/* Inverse of the CDF at u ∈ [0, 1], increasing in u. The textbook form
 * (1 + g² - s²)/(2g), s = (1-g²)/(1-g+2gu), loses digits as ~ε/|g| when
 * g → 0 (hence the usual isotropic special case, which is wrong by O(g)).
 * With a = 1-2u and d = 1-ga it equals, exactly,
 *   (-2a + g(a²+3) - 2g²a + g³(a²-1)) / (2d²),
 * whose error grows as ~ε/(1-|g|)² instead. Each is used where it is the
 * better: the error in cosθ stays within a few ε for every g. */
/* The two forms, written once for doubles and for the SIMD lanes'
 * vectors of doubles (transport/lanes.c), which must give the same bits:
 * u may be either, g a double or a vector. */
#define HV_HG_COS_SMALL_G(g, u) \
  ((-2.0 * (1.0 - 2.0 * (u)) + (g) * ((1.0 - 2.0 * (u)) * (1.0 - 2.0 * (u)) + 3.0 - \
    (g) * (2.0 * (1.0 - 2.0 * (u)) - (g) * ((1.0 - 2.0 * (u)) * (1.0 - 2.0 * (u)) - 1.0)))) / \
   (2.0 * (1.0 - (g) * (1.0 - 2.0 * (u))) * (1.0 - (g) * (1.0 - 2.0 * (u)))))
/* (1 + g² - s²)/(2g) with s = A/D, over one division. */
#define HV_HG_COS_LARGE_G(g, u) \
  (((1.0 + (g) * (g)) * ((1.0 - (g) + 2.0 * (g) * (u)) * (1.0 - (g) + 2.0 * (g) * (u))) - \
    ((1.0 - (g)) * (1.0 + (g))) * ((1.0 - (g)) * (1.0 + (g)))) / \
   (2.0 * (g) * ((1.0 - (g) + 2.0 * (g) * (u)) * (1.0 - (g) + 2.0 * (g) * (u)))))

static inline double hv_hg_sample_cos(double g, double u) {
  double c = fabs(g) < 1.0 / 3.0 ? HV_HG_COS_SMALL_G(g, u) : HV_HG_COS_LARGE_G(g, u);
  return c < -1.0 ? -1.0 : (c > 1.0 ? 1.0 : c);
}

/* ---- Directions --------------------------------------------------------- */

/* Orthonormal t, b completing unit n to a right-handed frame (t × b = n);
 * branchless, continuous except across n.z = 0 (Duff et al. 2017, JCGT 6(1)). */
static inline void hv_onb(const double n[3], double t[3], double b[3]) {
  double sign = copysign(1.0, n[2]);
  double a = -1.0 / (sign + n[2]);
  double c = n[0] * n[1] * a;
  t[0] = 1.0 + sign * n[0] * n[0] * a;
  t[1] = sign * c;
  t[2] = -sign * n[0];
  b[0] = c;
  b[1] = sign + n[1] * n[1] * a;
  b[2] = -n[1];
}

/* Taylor polynomials of sin f and cos f on [-π/4, π/4] (error < 1e-16),
 * f2 = f²; for doubles and for the lanes' vectors alike. */
#define HV_SIN_POLY(f, f2) \
  ((f) + (f) * (f2) * (-1.0 / 6 + (f2) * (1.0 / 120 + (f2) * (-1.0 / 5040 + (f2) * (1.0 / 362880 + \
   (f2) * (-1.0 / 39916800 + (f2) * (1.0 / 6227020800 + (f2) * (-1.0 / 1307674368000))))))))
#define HV_COS_POLY(f2) \
  (1.0 + (f2) * (-0.5 + (f2) * (1.0 / 24 + (f2) * (-1.0 / 720 + (f2) * (1.0 / 40320 + \
   (f2) * (-1.0 / 3628800 + (f2) * (1.0 / 479001600 + (f2) * (-1.0 / 87178291200 + \
   (f2) * (1.0 / 20922789888000)))))))))

/* sin and cos of 2π·u for u ∈ [0, 1): quadrant reduction (exact) and the
 * polynomials above. */
static inline void hv_sincos_2pi(double u, double *s, double *c) {
  double x = 4.0 * u;
  int iq = (int)(x + 0.5); /* x >= 0: truncation is floor, without a libm call */
  double f = (x - (double)iq) * 1.57079632679489661923;
  double f2 = f * f;
  double sp = HV_SIN_POLY(f, f2), cp = HV_COS_POLY(f2);
  /* The quadrant is a coin flip per scattering: selects by masks, not
   * branches (as branches they were 80 % of A1's mispredictions). */
  uint32_t q = (uint32_t)iq & 3u, odd = q & 1u;
  *s = hv_negate_if(hv_select(sp, cp, odd), q >> 1);
  *c = hv_negate_if(hv_select(cp, sp, odd), (q ^ (q >> 1)) & 1u);
}

/* The unit direction at angle θ from unit w (cosθ given) and azimuth
 * φ = 2π·turns about it (turns ∈ [0, 1)), measured in the frame of hv_onb(w). */
static inline void hv_dir_from_cos_phi(const double w[3], double cos_theta, double turns,
                                       double out[3]) {
  double t[3], b[3];
  hv_onb(w, t, b);
  double s2 = 1.0 - cos_theta * cos_theta;
  double sin_theta = s2 > 0.0 ? sqrt(s2) : 0.0;
  double sp, cp;
  hv_sincos_2pi(turns, &sp, &cp);
  double x = sin_theta * cp, y = sin_theta * sp;
  for (int i = 0; i < 3; ++i) out[i] = x * t[i] + y * b[i] + cos_theta * w[i];
}

/* ---- The family-generic interface --------------------------------------- */

static inline double hv_phase_eval(hv_phase_t p, double cos_theta) {
  switch (p.family) {
    case HV_PHASE_HG: return hv_hg_eval(p.g, cos_theta);
  }
  assert(!"unknown phase family");
  return 0.0;
}

static inline double hv_phase_dlog_dg(hv_phase_t p, double cos_theta) {
  switch (p.family) {
    case HV_PHASE_HG: return hv_hg_dlog_dg(p.g, cos_theta);
  }
  assert(!"unknown phase family");
  return 0.0;
}

/* cosθ distributed as the phase function, from a uniform u ∈ [0, 1]. */
static inline double hv_phase_sample_cos(hv_phase_t p, double u) {
  switch (p.family) {
    case HV_PHASE_HG: return hv_hg_sample_cos(p.g, u);
  }
  assert(!"unknown phase family");
  return 1.0;
}

/* Samples the outgoing direction wo for light travelling along wi from two
 * uniforms in [0, 1) (u1 → cosθ, u2 → φ = 2π u2); returns cosθ, which is what
 * hv_phase_eval and hv_phase_dlog_dg take. Every family is azimuthally
 * symmetric, so the pdf of wo is hv_phase_eval(p, cosθ) exactly. */
static inline double hv_phase_sample(hv_phase_t p, const double wi[3], double u1, double u2,
                                     double wo[3]) {
  double cos_theta = hv_phase_sample_cos(p, u1);
  hv_dir_from_cos_phi(wi, cos_theta, u2, wo);
  return cos_theta;
}

#endif
