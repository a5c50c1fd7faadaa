/**
 * @file acquire.h
 * @brief Simulated acquisition: sensor noise on rendered measurements, and
 *        synthetic volumes to recover.
 *
 * - hetinv_noise_apply() turns clean values (e.g. rendered radiance) into
 *   what a camera would record, with the affine noise model of Hasinoff,
 *   Durand & Freeman, "Noise-optimal capture for high dynamic range
 *   photography" (CVPR 2010): Poisson photon noise, Gaussian read noise and
 *   saturation at the full well.
 * - hetinv_volume_gaussian_mixture() fills a medium with the smooth random
 *   volumes of Fig. 4 of Gkioulekas et al. (ECCV 2016): each parameter a
 *   mixture of Gaussians, in 3D or as a 2D cross-section.
 * - hetinv_volume_smoke() fills a medium with a smooth smoke plume, like
 *   the dense heterogeneous volume of Fig. 5.
 *
 * Every generator is deterministic: its random numbers come from counter-
 * based streams keyed by the struct's seed and the index of what is drawn
 * (value, parameter, lattice point), never from the order of evaluation, so
 * results are the same bit for bit whatever the context's thread count.
 * These streams never coincide with the estimator's photon streams, even
 * with equal seeds.
 *
 * The spec structs start with their own size, like hetinv_context_init_t:
 * fill them with their *_default() function and change what you need.
 * The calls read only the members @c size covers and reject a @c size
 * smaller than the first version of the struct.
 *
 * Threads: each call may be made from any thread; the objects it writes
 * (arrays, the medium) belong to the calling thread for its duration.
 */
#ifndef HETINV_ACQUIRE_H
#define HETINV_ACQUIRE_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/medium.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Largest full well hetinv_noise_apply() accepts, in electrons. */
#define HETINV_NOISE_FULL_WELL_MAX 1e15

/**
 * @brief The affine sensor noise model (Hasinoff et al. 2010).
 *
 * A clean value v (any non-negative quantity, e.g. radiance) becomes
 * λ = exposure · v expected electrons. The sensor records
 * e = min(N + R, full_well) with N ~ Poisson(λ) and R ~ Normal(0, read_noise²),
 * and reports e / exposure, in the units of v. Values that end below zero
 * after the read noise are kept (not clamped at 0): the reported value is
 * then an unbiased estimate of v wherever the sensor does not saturate.
 */
typedef struct hetinv_noise_model {
  size_t size;       /**< sizeof(hetinv_noise_model_t); set by hetinv_noise_model_default() */
  double full_well;  /**< electrons at saturation; finite, in (0, HETINV_NOISE_FULL_WELL_MAX]. Default 20000. */
  double read_noise; /**< standard deviation of the additive Gaussian read noise, in electrons; finite, >= 0. Default 5. */
  double exposure;   /**< electrons per unit of value (exposure time and gain folded in), finite and > 0;
                          or 0 (default): automatic, the largest clean value maps to auto_level · full_well */
  double auto_level; /**< fraction of the full well the largest clean value reaches under automatic
                          exposure; in (0, 1], checked even when exposure is set. Default 0.9. */
  uint64_t seed;     /**< selects the noise realisation. Default 0. */
  uint64_t first_index; /**< random key of the first value: value i of a call draws from the stream
                             keyed by (seed, first_index + i), so noising a long array in chunks,
                             each with first_index = its offset, gives the same values as one call
                             (with a fixed exposure). first_index + count must be <= 2^48. Default 0. */
} hetinv_noise_model_t;

/**
 * @brief Fill @p model with the defaults: full_well 20000, read_noise 5,
 *        automatic exposure at auto_level 0.9, seed 0, first_index 0, and
 *        size = sizeof(hetinv_noise_model_t).
 * @param[out] model the struct to fill; NULL is a no-op. Thread-safe.
 */
HETINV_API void hetinv_noise_model_default(hetinv_noise_model_t *model);

/**
 * @brief Simulate a sensor's measurement of @p count clean values.
 *
 * For each value i, with E the exposure:
 * noisy[i] = min(N + R, full_well) / E with N ~ Poisson(E · clean[i]) and
 * R ~ Normal(0, read_noise²), and
 * std_errors[i] = sqrt(max(e, 0) + read_noise²) / E, where e = noisy[i] · E
 * is the recorded electron count: the model's standard deviation evaluated
 * at the measurement (the plug-in estimate, for 1/variance loss weights).
 * A saturated value (noisy[i] == full_well / E) carries no information on
 * how far above saturation the truth is; mask it in a loss.
 *
 * Randomness: value i draws from Philox streams keyed by (model->seed,
 * model->first_index + i), the Poisson count and the read noise from two
 * separate streams, so the result for one value does not depend on the
 * others or on the order of evaluation, and changing read_noise leaves the
 * Poisson counts unchanged. Poisson counts are exact: multiplication of
 * uniforms for λ < 10, Hörmann's transformed rejection (PTRS, 1993) above.
 * Means beyond 2^52 electrons (far above any allowed full well) are not
 * sampled: they saturate.
 *
 * @param ctx the context, for error reporting and its thread count.
 * @param model the noise model; read during the call only.
 * @param clean @p count values, each finite and >= 0. Read only.
 * @param[out] noisy receives @p count values. May be @p clean itself (noise
 *        in place); must not overlap it otherwise.
 * @param[out] std_errors receives @p count standard errors, or NULL if not
 *        wanted. Must not overlap @p clean or @p noisy.
 * @param count number of values, > 0.
 * @param[out] exposure_used receives the exposure applied (model->exposure,
 *        or the automatic one), or NULL if not wanted; 0 on failure.
 * @return HETINV_SUCCESS;
 *         HETINV_ERROR_NULL_ARGUMENT (ctx, model, clean, noisy);
 *         HETINV_ERROR_INVALID_ARGUMENT for a model field out of range (the
 *         message names the field and its value), count == 0 or
 *         first_index + count > 2^48, a clean value that is negative or not
 *         finite (the message names its index and value), or automatic
 *         exposure when every clean value is 0.
 *         Nothing is written on failure (validation precedes the noise).
 * Thread-safe for distinct output arrays.
 */
HETINV_API hetinv_result_t hetinv_noise_apply(hetinv_context_t *ctx,
                                              const hetinv_noise_model_t *model,
                                              const double *clean, double *noisy,
                                              double *std_errors, size_t count,
                                              double *exposure_used);

/** Most Gaussians per parameter of a mixture volume. */
#define HETINV_MIXTURE_COMPONENTS_MAX 16

/**
 * @brief A random Gaussian-mixture volume (Fig. 4 of the paper).
 *
 * For each parameter p (σa, σs, g) independently,
 * m_p(x) = Σ_c w_c exp(-|x - μ_c|² / (2 s_c²)), c = 1..components, with
 * centres μ_c uniform in the box, widths s_c uniform in
 * [min_width, max_width] · L (L the box's largest side among the axes the
 * field varies along) and weights w_c uniform in (0.25, 1]; |x - μ_c|
 * ignores the constant axis. m_p is evaluated at voxel centres, then mapped
 * affinely so that its minimum over the voxels becomes lo[p] and its maximum
 * hi[p], both exactly; a field equal at every voxel becomes (lo[p] + hi[p]) / 2.
 */
typedef struct hetinv_mixture_spec {
  size_t size;           /**< sizeof(hetinv_mixture_spec_t); set by hetinv_mixture_spec_default() */
  double lo[3];          /**< least value of σa, σs, g (indexed by enum hetinv_param_id) */
  double hi[3];          /**< greatest value of each parameter; lo[p] <= hi[p], σ >= 0, -1 < g < 1 */
  int32_t components;    /**< Gaussians per parameter, in [1, HETINV_MIXTURE_COMPONENTS_MAX]. Default 2. */
  double min_width;      /**< least standard deviation of a Gaussian, as a fraction of L; finite, > 0. Default 0.15. */
  double max_width;      /**< greatest standard deviation, fraction of L; finite, >= min_width. Default 0.4. */
  int32_t constant_axis; /**< -1: a 3D field; 0, 1 or 2: the field does not vary along x, y or z
                              (a 2D cross-section). Default -1. */
  uint64_t seed;         /**< selects the volume. Default 0. */
} hetinv_mixture_spec_t;

/**
 * @brief Fill @p spec with the defaults: σa in [0.05, 0.5], σs in [1, 10]
 *        (per unit length), g in [0, 0.9], 2 components, widths 0.15..0.4,
 *        a 3D field, seed 0, and size = sizeof(hetinv_mixture_spec_t).
 * @param[out] spec the struct to fill; NULL is a no-op. Thread-safe.
 */
HETINV_API void hetinv_mixture_spec_default(hetinv_mixture_spec_t *spec);

/**
 * @brief Set σa, σs and g of every voxel of @p medium to a random Gaussian
 *        mixture (see hetinv_mixture_spec_t).
 * @param medium an uncommitted medium; its grid and box define the voxels.
 * @param spec the volume; read during the call only.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_STATE if the medium is committed;
 *         HETINV_ERROR_INVALID_ARGUMENT for a spec field out of range (the
 *         message names the field and its value);
 *         HETINV_ERROR_OUT_OF_MEMORY. Nothing changes on failure.
 * Deterministic under spec->seed, whatever the thread count.
 */
HETINV_API hetinv_result_t hetinv_volume_gaussian_mixture(hetinv_medium_t *medium,
                                                          const hetinv_mixture_spec_t *spec);

/** Most octaves of a smoke volume's noise. */
#define HETINV_SMOKE_OCTAVES_MAX 6
/** Least feature size of a smoke volume (fraction of the box's largest side). */
#define HETINV_SMOKE_FEATURE_MIN 0.02

/**
 * @brief A smooth smoke plume (like Fig. 5 of the paper).
 *
 * The plume rises along +y. A density d(x) in [0, 1] is a swirling column
 * (a Gaussian profile around a random helical vertical axis, of radius 5–8 %
 * of the box's smaller horizontal side at the bottom widening 2.5× to the
 * top, plus five Gaussian puffs along it) multiplied by fractal value noise
 * (octaves of a random lattice with quintic, C² interpolation; lattice
 * spacing feature_size · L for the first octave, halved at each further
 * octave, amplitude halved too), normalised so its maximum over the voxels
 * is 1. Then σs = lo + (hi − lo)·d, σa the same with a weaker, independent
 * noise modulation of d, and g = lo + (hi − lo)·n from an independent smooth
 * noise field n in [0, 1]. Every value lies in [lo[p], hi[p]]; σs takes
 * hi[1] exactly at the densest voxel. The noise is smooth on the scale of
 * feature_size / 2^(octaves−1), the column on the scale of its radius.
 */
typedef struct hetinv_smoke_spec {
  size_t size;         /**< sizeof(hetinv_smoke_spec_t); set by hetinv_smoke_spec_default() */
  double lo[3];        /**< least value of σa, σs, g (indexed by enum hetinv_param_id) */
  double hi[3];        /**< greatest value of each parameter; lo[p] <= hi[p], σ >= 0, -1 < g < 1 */
  int32_t octaves;     /**< octaves of fractal noise, in [1, HETINV_SMOKE_OCTAVES_MAX]. Default 3. */
  double feature_size; /**< lattice spacing of the first octave as a fraction of L (the box's largest
                            side), in [HETINV_SMOKE_FEATURE_MIN, 1]. Default 0.25. */
  uint64_t seed;       /**< selects the volume. Default 0. */
} hetinv_smoke_spec_t;

/**
 * @brief Fill @p spec with the defaults: σa in [0.01, 0.5], σs in [0.1, 20],
 *        g in [0.3, 0.8], 3 octaves, feature size 0.25, seed 0, and
 *        size = sizeof(hetinv_smoke_spec_t).
 * @param[out] spec the struct to fill; NULL is a no-op. Thread-safe.
 */
HETINV_API void hetinv_smoke_spec_default(hetinv_smoke_spec_t *spec);

/**
 * @brief Set σa, σs and g of every voxel of @p medium to a smoke plume
 *        (see hetinv_smoke_spec_t).
 * @param medium an uncommitted medium; its grid and box define the voxels.
 * @param spec the volume; read during the call only.
 * @return as hetinv_volume_gaussian_mixture(). Nothing changes on failure.
 * Deterministic under spec->seed, whatever the thread count.
 */
HETINV_API hetinv_result_t hetinv_volume_smoke(hetinv_medium_t *medium,
                                               const hetinv_smoke_spec_t *spec);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_ACQUIRE_H */
