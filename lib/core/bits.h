/* Branch-free selects on doubles, by their bits. A compiler may turn
 * `c ? a : b` on doubles into a branch; where c is a coin flip (a random
 * quadrant, the axis a walk crosses next), that branch mispredicts half
 * the time. These compile to masks and give bitwise the select's value. */
#ifndef HV_BITS_H
#define HV_BITS_H

#include <stdint.h>
#include <string.h>

static inline uint64_t hv_bits_of(double x) {
  uint64_t u;
  memcpy(&u, &x, sizeof u);
  return u;
}

static inline double hv_double_of(uint64_t u) {
  double x;
  memcpy(&x, &u, sizeof x);
  return x;
}

/* x if keep is 1, +0 if it is 0. */
static inline double hv_keep_if(double x, uint32_t keep) {
  return hv_double_of(hv_bits_of(x) & -(uint64_t)keep);
}

/* b if pick_b is 1, a if it is 0. */
static inline double hv_select(double a, double b, uint32_t pick_b) {
  uint64_t m = -(uint64_t)pick_b;
  return hv_double_of((hv_bits_of(a) & ~m) | (hv_bits_of(b) & m));
}

/* -x if negate is 1, x if it is 0 (IEEE negation flips the sign bit alone). */
static inline double hv_negate_if(double x, uint32_t negate) {
  return hv_double_of(hv_bits_of(x) ^ ((uint64_t)negate << 63));
}

#endif
