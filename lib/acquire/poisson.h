/* Exact Poisson variates from a counter-based stream: multiplication of
 * uniforms (Knuth) below HV_POISSON_PTRS_MIN, Hörmann's transformed
 * rejection with squeeze (PTRS; "The transformed rejection method for
 * generating Poisson random variables", Insurance: Mathematics and Economics
 * 12, 1993) from there on. */
#ifndef HV_POISSON_H
#define HV_POISSON_H

#include "core/rng.h"

/* PTRS is valid for λ >= 10 (Hörmann's constants are fitted from there). */
#define HV_POISSON_PTRS_MIN 10.0
/* Largest mean sampled: counts up to ~2^52 + 2^30 are still exact doubles. */
#define HV_POISSON_LAMBDA_MAX 0x1p52

/* log(k!) for an integer-valued k >= 0: exact products below 16, the
 * Stirling series (error < 1e-17 relative) from there on. */
double hv_log_factorial(double k);

/* A Poisson(lambda) count, 0 <= lambda <= HV_POISSON_LAMBDA_MAX, as a double
 * holding an integer; lambda == 0 gives 0 without drawing. */
double hv_poisson_sample(double lambda, hv_rng_t *rng);

#endif
