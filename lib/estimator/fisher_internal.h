/* What the dense Fisher matrix (fisher.c) and its matrix-free estimates
 * (fisher.c's diagonal, fisher_blocks.c) share. */
#ifndef HV_FISHER_INTERNAL_H
#define HV_FISHER_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "estimator/pass.h"

/* Checks the arguments every entry point shares (the map against the
 * medium and k; replicates, named replicates_name in the message, from 2
 * to HETINV_FISHER_MAX_REPLICATES; k at most
 * HETINV_FISHER_MAX_ENTRIES if dense) and builds the weights
 * mask_n / variance_n (variances NULL: the set's standard errors squared)
 * into *weights, allocated in the pass's context. */
hetinv_result_t hv_fisher_check(const hv_pass_t *pass, const hetinv_medium_t *medium,
                                const hetinv_measurements_t *set, const double *variances,
                                const hetinv_param_map_t *map, int32_t replicates,
                                const char *replicates_name, size_t k, bool dense,
                                double **weights);

/* ±1, entry i of probe r: a SplitMix64 hash of (seed, probe, i),
 * independent of the photons (another generator altogether). */
double hv_fisher_rademacher(uint64_t seed, int32_t probe, size_t i);

/* From the sums of R ≥ 2 samples and of their squares, n entries: the
 * means, and (se not NULL) their standard errors, spread / √R. */
void hv_fisher_mean_se(const double *sum, const double *sq, size_t n, int32_t R, double *mean, double *se);

#endif
