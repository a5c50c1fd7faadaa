/* The medium's boundary: a smooth dielectric interface. Inline, because
 * every next-event connection crosses it.
 *
 * Conventions (DESIGN §1): eta = η_t/η_i, the index on the far (transmitted)
 * side over the index on the near side; leaving a medium of index η into air
 * is eta = 1/η. Radiance refracted into the far side is multiplied by
 * (1 - R)·eta² (radiance is not invariant across an index change: L/η² is);
 * flux, and so the photon weight of light tracing, is multiplied by (1 - R)
 * only, the eta² being absorbed by the change of solid angle. An index-matched
 * boundary (eta = 1) has R = 0 and does not bend light. */
#ifndef HV_FRESNEL_H
#define HV_FRESNEL_H

#include <assert.h>
#include <math.h>
#include <stdbool.h>

/* Unpolarised reflectance (mean of s and p) for incidence cosine cos_i ∈ [0, 1]
 * measured on the near side. Stores the refracted cosine (≥ 0) in *cos_t, or 0
 * under total internal reflection, where R = 1. */
static inline double hv_fresnel_dielectric(double cos_i, double eta, double *cos_t) {
  assert(cos_i >= 0.0 && cos_i <= 1.0 && eta > 0.0);
  if (eta == 1.0) { /* index matched: exactly invisible, not merely to rounding */
    *cos_t = cos_i;
    return 0.0;
  }
  double sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.0) {
    *cos_t = 0.0;
    return 1.0;
  }
  double ct = sqrt(1.0 - sin2_t);
  double rs = (cos_i - eta * ct) / (cos_i + eta * ct);
  double rp = (eta * cos_i - ct) / (eta * cos_i + ct);
  *cos_t = ct;
  return 0.5 * (rs * rs + rp * rp);
}

/* Cosine of the critical angle on the near side: below it (more grazing) light
 * is totally reflected. 0 (no total reflection) when eta ≥ 1. */
static inline double hv_fresnel_critical_cos(double eta) {
  return eta >= 1.0 ? 0.0 : sqrt(1.0 - eta * eta);
}

/* Mirror reflection of w about the plane with unit normal n (either side). */
static inline void hv_reflect(const double w[3], const double n[3], double out[3]) {
  double wn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
  for (int i = 0; i < 3; ++i) out[i] = w[i] - 2.0 * wn * n[i];
}

/* Refracted direction of unit w (travelling toward the interface) through the
 * plane with unit normal n (either orientation), with cos_t from
 * hv_fresnel_dielectric for the same cos_i and eta (so the hot path computes
 * the square root once). Snell: wt = w/eta + (cos_i/eta - cos_t)·m, with m the
 * normal facing back against w. */
static inline void hv_refract_cos(const double w[3], const double n[3], double eta, double cos_t,
                                  double wt[3]) {
  double wn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
  double sign = wn > 0.0 ? -1.0 : 1.0; /* m = sign·n faces against w */
  double cos_i = fabs(wn);
  double k = (cos_i / eta - cos_t) * sign;
  for (int i = 0; i < 3; ++i) wt[i] = w[i] / eta + k * n[i];
}

/* Convenience: the refracted direction, or false under total internal
 * reflection (wt untouched). */
static inline bool hv_refract(const double w[3], const double n[3], double eta, double wt[3]) {
  double wn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
  double sin2_t = (1.0 - wn * wn) / (eta * eta);
  if (sin2_t >= 1.0) return false;
  hv_refract_cos(w, n, eta, sqrt(1.0 - sin2_t), wt);
  return true;
}

/* Factor on radiance transmitted with reflectance R through an interface of
 * relative index eta: (1 - R)·eta², so that L/η² is conserved. */
static inline double hv_fresnel_radiance_scale(double R, double eta) {
  return (1.0 - R) * eta * eta;
}

#endif
