/**
 * @file bound.h
 * @brief What measurements can determine: the Fisher information of the
 *        free parameters and their Cramér–Rao bound.
 *
 * For rendered values I_n(π) measured with independent noise of variance
 * σ²_n, the Fisher information of the parameter-map entries π is
 * F = Jᵀ Σ⁻¹ J with J_nk = ∂I_n/∂π_k and Σ = diag(σ²_n); any unbiased
 * estimate of π_k has a standard deviation of at least sqrt((F⁻¹)_kk),
 * the Cramér–Rao bound (CRB). Values outside the set's mask do not count.
 *
 * The estimate of F is unbiased under Monte Carlo noise. Each of R
 * independent replicates forms J column by column with one tangent pass
 * of K one-hot tangents (hetinv_estimator_jvp() for every e_k at once:
 * this does form J, K doubles per value, which is why K is limited to
 * #HETINV_FISHER_MAX_ENTRIES), twice, from the independent photon streams
 * s + 2r and s + 2r + 1 (s: the estimator's HETINV_ESTIMATOR_STREAM):
 * F_r = ½(Ĵ₁ᵀΣ⁻¹Ĵ₂ + Ĵ₂ᵀΣ⁻¹Ĵ₁), whose expectation is F exactly because
 * the factors share no photon. F̂ is the mean of the F_r and each entry's
 * standard error is their spread / √R. One replicate costs two tangent
 * passes, each roughly a render plus O(K) work per path event and splat.
 *
 * The bound sqrt((F̂⁻¹)_kk) is a smooth function of an unbiased F̂, so it
 * is consistent but biased by O(1/photons) (by Jensen's inequality the
 * inverse of a noisy matrix is, on average, larger); its standard error
 * is the jackknife's over the R replicates. sqrt(1/F̂_kk) is also given:
 * it is a LOWER bound on the CRB standard deviation ((F⁻¹)_kk ≥ 1/F_kk
 * for a positive definite F), i.e. what entry k could reach if every
 * other entry were known.
 *
 * Costs: 2R tangent passes (a voxel crossing costs O(1) for one-hot
 * tangents, a splat O(K)) and R products ĴᵀWĴ of O(values·K²), parallel
 * over the context's threads; memory 2·values·K + R·K² doubles, plus per
 * thread K doubles for each value of one emitter, plus 3·voxels·K for the
 * pushed-forward tangents; the inversion is O(K³) per replicate
 * (jackknife).
 */
#ifndef HETINV_BOUND_H
#define HETINV_BOUND_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/estimator.h"
#include "hetinv/export.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Largest parameter map (hetinv_param_map_size()) the dense Fisher
 *  matrix and the bound accept. */
#define HETINV_FISHER_MAX_ENTRIES 2048

/** Largest number of replicates of the Fisher matrix. */
#define HETINV_FISHER_MAX_REPLICATES 1024

/**
 * @brief Unbiased estimate of the Fisher information F = Jᵀ Σ⁻¹ J of the
 *        map's entries, with standard errors (see the file's description).
 * @param estimator the estimator: its photons, batches, stream s and epoch
 *        are used; the replicates use streams s + 2r and s + 2r + 1.
 * @param medium committed medium at which J is taken (e.g. the truth).
 * @param set the measurement set: its layout and mask (values with mask 0
 *        are left out); with @p variances NULL also its standard errors.
 * @param variances @p count noise variances σ²_n of the measured values
 *        (the acquisition model's); NULL: the set's standard errors
 *        squared. Each value in the mask needs a finite positive variance.
 * @param count the set's value count.
 * @param map parameter map made for the medium's grid.
 * @param replicates R, independent estimates averaged (2 to
 *        #HETINV_FISHER_MAX_REPLICATES); more give smaller error bars.
 * @param[out] fisher receives F̂, k·k values, row-major, symmetric.
 * @param[out] fisher_std_errors the standard error of each entry (spread of
 *        the replicates / √R, R − 1 degrees of freedom); may be NULL.
 * @param k hetinv_param_map_size(map), at most #HETINV_FISHER_MAX_ENTRIES.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (count, k, replicates, a variance,
 *         the map's grid, the medium's box); HETINV_ERROR_INVALID_STATE
 *         (medium not committed); HETINV_ERROR_UNSUPPORTED (a context with
 *         several MPI ranks); HETINV_ERROR_OUT_OF_MEMORY;
 *         HETINV_ERROR_SIZE_OVERFLOW.
 */
HETINV_API hetinv_result_t hetinv_estimator_fisher(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t replicates,
    double *fisher, double *fisher_std_errors, size_t k);

/**
 * @brief Per-entry Cramér–Rao standard deviation sqrt((F⁻¹)_kk), from the
 *        Fisher matrix of hetinv_estimator_fisher() (same arguments).
 *
 * F̂ is inverted through its Cholesky factor, without regularisation.
 * Entries whose diagonal is exactly zero in every replicate (no path
 * reaches them, or the mask hides every value they affect) cannot be
 * determined at all: their bound is +∞ and they are left out of the
 * inversion. If the rest of F̂ is not positive definite (Monte Carlo noise
 * in a nearly singular F, or parameters the measurements cannot tell
 * apart), *positive_definite is 0, the bound is NaN and only @p sd_lower
 * is meaningful; more photons or replicates, or a coarser map, help.
 * @param estimator as for hetinv_estimator_fisher().
 * @param medium as for hetinv_estimator_fisher().
 * @param set as for hetinv_estimator_fisher().
 * @param variances as for hetinv_estimator_fisher().
 * @param count as for hetinv_estimator_fisher().
 * @param map as for hetinv_estimator_fisher().
 * @param replicates as for hetinv_estimator_fisher().
 * @param[out] sd receives k standard deviations, in the units of π.
 * @param[out] sd_std_errors their jackknife standard errors over the
 *        replicates (NaN if a leave-one-out matrix is not positive
 *        definite; 0 for an infinite bound, which is exact); may be NULL.
 * @param[out] sd_lower receives sqrt(1/F̂_kk), a LOWER bound on the CRB
 *        standard deviation (NaN where F̂_kk ≤ 0 from noise); may be NULL.
 * @param k hetinv_param_map_size(map).
 * @param[out] positive_definite receives 1 if F̂ (without its unseen
 *        entries) is positive definite, else 0; may be NULL.
 * @return as hetinv_estimator_fisher(); a matrix that is not positive
 *         definite is a result, not an error.
 */
HETINV_API hetinv_result_t hetinv_estimator_crb(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t replicates,
    double *sd, double *sd_std_errors, double *sd_lower, size_t k, int32_t *positive_definite);

/**
 * @brief Matrix-free, unbiased estimate of the diagonal of F, for maps too
 *        large for the dense matrix (any K).
 *
 * Hutchinson's estimator: for each of R Rademacher probes z (±1 entries
 * from a hash of the context seed, the epoch, the probe and the entry,
 * independent of the photons), one tangent pass gives Ĵ₁z on stream
 * s + 2r and one gradient pass gives Ĵ₂ᵀ(Σ⁻¹Ĵ₁z) on stream s + 2r + 1;
 * z ⊙ Ĵ₂ᵀΣ⁻¹Ĵ₁z has expectation F_kk exactly (E[z_k z_j] = δ_kj and the
 * passes share no photon). Its spread holds Σ_{j≠k} F_kj² besides the
 * Monte Carlo noise, so where neighbouring entries are strongly
 * correlated many probes are needed; each costs two passes whatever K.
 *
 * With it, sqrt(1/F_kk) is a LOWER bound on the CRB standard deviation
 * sqrt((F⁻¹)_kk) (equal only when entry k is uncorrelated with the
 * others): what entry k could reach if all the others were known. It is
 * not the bound itself; use hetinv_estimator_crb() where K allows.
 * @param estimator as for hetinv_estimator_fisher().
 * @param medium as for hetinv_estimator_fisher().
 * @param set as for hetinv_estimator_fisher().
 * @param variances as for hetinv_estimator_fisher().
 * @param count as for hetinv_estimator_fisher().
 * @param map as for hetinv_estimator_fisher().
 * @param probes R, from 2 to #HETINV_FISHER_MAX_REPLICATES.
 * @param[out] diagonal receives k estimates of F_kk (a single one can be
 *        ≤ 0 from noise).
 * @param[out] diagonal_std_errors their standard errors (spread of the
 *        probes / √R, R − 1 degrees of freedom); may be NULL.
 * @param k hetinv_param_map_size(map).
 * @return as hetinv_estimator_fisher(), without the limit on k.
 */
HETINV_API hetinv_result_t hetinv_estimator_fisher_diagonal(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t probes,
    double *diagonal, double *diagonal_std_errors, size_t k);

/**
 * @brief Local Cramér–Rao bound from a Fisher matrix, for maps whose F̂
 *        cannot be estimated positive definite at an affordable photon
 *        count: entry k's bound when only the entries within @p radius
 *        cells of its own cell are unknown and every other entry is known.
 *
 * For each cell of the map, W is every free parameter of every cell at
 * Chebyshev distance ≤ radius on the map's grid (hetinv_param_map_get_dims())
 * and sd_k = sqrt(((F_WW)⁻¹)_kk). For nested windows this never decreases
 * with the radius, and it is a LOWER bound on the CRB sqrt((F⁻¹)_kk) of
 * hetinv_estimator_crb(), which it reaches once the window holds every
 * entry: radius 0 separates the parameters of one cell (σa, σs and g of a
 * voxel, which steady light confounds), radius 1 also its neighbours (a
 * correct sum split wrongly between two voxels). Where the full F̂ is not
 * positive definite, the radius at which the windows stop being positive
 * definite is itself what the data cannot resolve at this precision.
 * Pure linear algebra: O(cells · (3(2r+1)^d)³).
 * @param map the map F was estimated for.
 * @param fisher k·k values, row-major, symmetric (hetinv_estimator_fisher()).
 * @param k hetinv_param_map_size(map).
 * @param radius 0 or more; its windows may hold at most
 *        #HETINV_FISHER_MAX_ENTRIES entries.
 * @param[out] sd k standard deviations in the units of π: +∞ where F_kk is
 *        exactly 0 (nothing reaches the entry), NaN where the window's
 *        matrix is not positive definite.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (k, radius);
 *         HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_fisher_local_crb(const hetinv_param_map_t *map, const double *fisher,
                                                   size_t k, int32_t radius, double *sd);

/**
 * @brief Matrix-free, unbiased estimate of the Fisher matrix's blocks on
 *        its diagonal, one per cell of the map, for maps of any size: what
 *        the local bound at radius 0 needs (hetinv_fisher_blocks_crb()).
 *
 * A cell's block is F restricted to the cell's own P free parameters
 * (P = k / cells). The cells are split into classes by their coordinates
 * modulo @p spacing; each probe z puts random signs (a hash of the context
 * seed, the replicate, the probe and the entry, independent of the
 * photons) on one free parameter of one class's cells. A tangent pass
 * (stream s + 2r, all probes of replicate r at once) and a gradient pass
 * per probe (stream s + 2r + 1) give g = Ĵ₂ᵀ W Ĵ₁ z, and s_{cp} g_{cb} has
 * expectation F_{cb,cp} exactly. Besides the Monte Carlo noise its spread
 * holds the entries F_{cb,j} of the other cells j of the class, which
 * fall off with their distance (≥ spacing cells on some axis): a wider
 * spacing gives less noise for more passes. Blocks are symmetrised.
 *
 * Costs per replicate: one tangent pass of T = classes·P tangents and T
 * gradient passes, classes = spacing³ (fewer on axes with fewer cells);
 * memory 3·voxels·T + values·T + T·k doubles.
 * @param estimator as for hetinv_estimator_fisher().
 * @param medium as for hetinv_estimator_fisher().
 * @param set as for hetinv_estimator_fisher().
 * @param variances as for hetinv_estimator_fisher().
 * @param count as for hetinv_estimator_fisher().
 * @param map as for hetinv_estimator_fisher().
 * @param spacing 1 to 16 (1: one class, every cell probed at once).
 * @param replicates R, from 2 to #HETINV_FISHER_MAX_REPLICATES.
 * @param[out] blocks cells·P·P values: cell c's block at
 *        blocks[(c·P + a)·P + b] = F_{a·cells + c, b·cells + c}.
 * @param[out] blocks_std_errors their standard errors (spread of the
 *        replicates / √R); may be NULL.
 * @param k hetinv_param_map_size(map).
 * @return as hetinv_estimator_fisher_diagonal(); HETINV_ERROR_INVALID_ARGUMENT
 *         for a spacing out of range.
 */
HETINV_API hetinv_result_t hetinv_estimator_fisher_blocks(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *variances, size_t count, const hetinv_param_map_t *map, int32_t spacing,
    int32_t replicates, double *blocks, double *blocks_std_errors, size_t k);

/**
 * @brief The local Cramér–Rao bound at radius 0 from the blocks of
 *        hetinv_estimator_fisher_blocks(): entry k's bound when only its
 *        own cell's parameters are unknown, sqrt of the diagonal of each
 *        block's inverse. It is a LOWER bound of the full bound
 *        sqrt((F⁻¹)_kk), and at least sqrt(1/F_kk).
 * @param map the parameter map.
 * @param blocks cells·P·P values, as hetinv_estimator_fisher_blocks() writes.
 * @param k hetinv_param_map_size(map).
 * @param[out] sd k standard deviations in the units of π: +∞ where the
 *        block's diagonal entry is 0 (nothing seen), NaN where the rest of
 *        the cell's block is not positive definite (noise: more replicates
 *        or a wider spacing).
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (k); HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_fisher_blocks_crb(const hetinv_param_map_t *map, const double *blocks,
                                                    size_t k, double *sd);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_BOUND_H */
