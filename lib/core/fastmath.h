/* Elementary functions for the photon loop, inline and deterministic (plain
 * IEEE arithmetic, no libm call): the free-flight sampling takes a log per
 * collision, which libm makes a fifth of the loop's time. */
#ifndef HV_FASTMATH_H
#define HV_FASTMATH_H

#include <stdint.h>
#include <string.h>

/* Natural log of a positive, finite, normal x, within 2 ulp of the true value.
 * x = m·2^e with m in [√½, √2); log m = 2·atanh(s), s = (m-1)/(m+1),
 * |s| ≤ 0.1716, summed as an odd series to s^21 (remainder < 1e-17). */
static inline double hv_log(double x) {
  uint64_t bits;
  memcpy(&bits, &x, sizeof bits);
  int e = (int)((bits >> 52) & 0x7ff) - 1023;
  bits = (bits & UINT64_C(0x000fffffffffffff)) | UINT64_C(0x3ff0000000000000); /* m in [1, 2) */
  double m;
  memcpy(&m, &bits, sizeof m);
  if (m > 1.4142135623730951) {
    m *= 0.5;
    ++e;
  }
  double s = (m - 1.0) / (m + 1.0), s2 = s * s, s4 = s2 * s2;
  /* Σ_{k=0..10} s2^k/(2k+1): the small high-order terms as a short tree
   * (Estrin) so they do not form a long chain of dependent operations, the
   * three leading terms last and in order (Horner), where the accuracy is. */
  double high = ((1.0 / 7 + s2 * (1.0 / 9)) + s4 * (1.0 / 11 + s2 * (1.0 / 13))) +
                s4 * s4 * ((1.0 / 15 + s2 * (1.0 / 17)) + s4 * (1.0 / 19 + s2 * (1.0 / 21)));
  double series = 1.0 + s2 * (1.0 / 3 + s2 * (1.0 / 5 + s2 * high));
  /* e·ln2 split in a high part exact for |e| < 2^11 and a low correction. */
  return (double)e * 6.93147180369123816490e-01 + ((double)e * 1.90821492927058770002e-10 + 2.0 * s * series);
}

#endif
