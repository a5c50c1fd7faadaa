/**
 * @file estimator.h
 * @brief The Monte Carlo estimator: renders a measurement set for a medium.
 *
 * Light tracing from each emitter: exact free-flight sampling through the
 * piecewise-constant voxel grid, Henyey–Greenstein scattering, Fresnel
 * reflection and refraction (with total internal reflection) at every
 * boundary hit, and Russian roulette on low weights. At every scattering
 * vertex a next-event connection is made to every orthographic sensor that
 * can see it, through the sensor's refracted interior direction;
 * hemispherical detectors score the power of the light that leaves through
 * them. The pathlength of a contribution is the geometric length travelled
 * inside the medium up to the exit point.
 *
 * Determinism: the random numbers of photon i of emitter e are a Philox
 * stream keyed by (context seed, stream parameter, e, i), and photons are
 * summed in batches reduced in a fixed order (per emitter, then over
 * emitters in emitter order), so results are bitwise identical whatever
 * the number of threads, and in a build with MPI whatever the number of
 * ranks (hetinv/mpi.h). The batches also give each value's standard error
 * (from the spread of batch means).
 *
 * An estimator belongs to one thread at a time; it runs its own parallel
 * loop with the context's thread count. When the context has several MPI
 * ranks (hetinv_context_rank_count() > 1), render, gradient and
 * loss_gradient are collective: every rank makes the same calls with the
 * same arguments and receives the same results.
 *
 * Memory: after a gradient pass the estimator keeps that pass's per-voxel
 * scratch (about 33 bytes per voxel per thread, plus 57 per voxel) for the
 * next one on a grid of the same size, which then allocates and clears
 * nothing of that size; hetinv_estimator_destroy() frees it. While a call
 * runs on several threads, each thread but the first reads its own copy
 * of the grid's per-voxel records (33 bytes per voxel) when they exceed
 * 1 MB, up to 1 GB of copies: two cores reading one large array served
 * each other's cache misses. Every pass keeps the grid's records and these
 * copies too, for the next pass on a grid of the same voxel count, which
 * then writes its values into pages already mapped (a grid of another
 * size frees them first).
 */
#ifndef HETINV_ESTIMATOR_H
#define HETINV_ESTIMATOR_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/measurement.h"
#include "hetinv/medium.h"
#include "hetinv/param.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Opaque estimator handle. */
typedef struct hetinv_estimator hetinv_estimator_t;

/** A tunable of the estimator: a value of enum hetinv_estimator_param_id. */
typedef int32_t hetinv_estimator_param_t;

/** Estimator tunables; see hetinv_estimator_param_bounds(). Pinned values. */
enum hetinv_estimator_param_id {
  /** Photons traced per emitter (default 100000; an integer in [1, 2^48 − 1]). */
  HETINV_ESTIMATOR_PHOTONS = 0,
  /** Batches the photons of each emitter are split into, for standard errors
   *  and parallel work (default 64; integer in [2, 65536]; capped at the
   *  photon count). Changing it changes the result's rounding, not its
   *  expectation. */
  HETINV_ESTIMATOR_BATCHES = 1,
  /** Russian roulette starts when a photon's weight, relative to its
   *  emitter's power, falls below this (default 1e-4; [0, 1]; 0 disables
   *  roulette). */
  HETINV_ESTIMATOR_ROULETTE_WEIGHT = 2,
  /** Probability that a photon survives a roulette (default 0.1; [1e-6, 1]). */
  HETINV_ESTIMATOR_ROULETTE_SURVIVAL = 3,
  /** Only light scattered at least this many times contributes (default 0). */
  HETINV_ESTIMATOR_MIN_SCATTERING = 4,
  /** Only light scattered at most this many times contributes; photons stop
   *  after it (default HETINV_ESTIMATOR_DEFAULT_MAX_SCATTERING; integer in
   *  [0, 1e9]). MIN = MAX = 1 gives single scattering. 0 means unlimited:
   *  then a photon in a medium whose albedo rounds to 1 (σs ≫ σa, e.g.
   *  σs = 1e308) may scatter for ever and the render never ends. Paths
   *  stopped by the bound are counted in hetinv_render_stats_t::truncated_paths
   *  and their power in hetinv_render_stats_t::truncated. */
  HETINV_ESTIMATOR_MAX_SCATTERING = 5,
  /** Random stream id (default 0; integer in [0, 65535]): renders with
   *  different streams are independent, with the same stream identical. */
  HETINV_ESTIMATOR_STREAM = 6,
  /** Epoch (default 0; integer in [0, 2^53]): mixed into the context's seed,
   *  so an optimiser can draw fresh paths at every iteration. */
  HETINV_ESTIMATOR_EPOCH = 7,
  /** Robust loss of hetinv_estimator_loss_gradient() (default 0; a number in
   *  [0, 1e6]). A value n of weight w and residual r = I − Ī contributes
   *  w·r² while √w·|r| ≤ c, and 2·c·√w·|r| − c² beyond (Huber's loss, with c
   *  in standard errors when w is 1/variance), so its cotangent is clipped
   *  at ±2·c·√w. 0 keeps least squares (Eq. 9). For Monte Carlo data whose
   *  dim values have heavy-tailed errors (a rare path hundreds of times the
   *  value), where 1/variance from the data's own batch means trusts such a
   *  value far too much. */
  HETINV_ESTIMATOR_LOSS_CLIP = 8,
  HETINV_ESTIMATOR_PARAM_COUNT_ = 9 /**< not a parameter: one past the last */
};

/**
 * Default of HETINV_ESTIMATOR_MAX_SCATTERING: scattering events after which
 * a photon path is stopped (and counted as truncated).
 *
 * Each event costs of the order of a microsecond, so one photon costs at
 * most about a second. A path survives 10^6 scatterings without being
 * absorbed, leaving the box or losing a Russian roulette only where the
 * albedo is within about 10^-5 of 1 and the box is more than about a
 * thousand mean free paths across (a diffusing photon crosses T mean free
 * paths in about T² events). Elsewhere the power such paths carry is far
 * below any value's Monte Carlo error. Where both hold the bound biases
 * the values: through 10^4 mean free paths of a pure scatterer the
 * transmittance comes out 0 where about 1.7e-4 is right, and the
 * reflectance 14 standard errors low at 10^5 photons. The statistics report
 * the power stopped (hetinv_render_stats_t::truncated); set this parameter
 * higher, or 0, for such media (hetinv-render warns).
 */
#define HETINV_ESTIMATOR_DEFAULT_MAX_SCATTERING 1000000

/**
 * @brief Statistics of the last render, as fractions of the emitted power,
 *        averaged over the set's emitters, with standard errors.
 *
 * The struct begins with its size: set @c size = sizeof(hetinv_render_stats_t)
 * before calling hetinv_estimator_get_stats(), which fills only the members
 * that @c size covers.
 */
typedef struct hetinv_render_stats {
  size_t size;               /**< sizeof(hetinv_render_stats_t), set by the caller */
  uint64_t photons;          /**< photons traced in all */
  double seconds;            /**< wall-clock time of the render */
  double specular;           /**< reflected at the first surface; never entered */
  double absorbed;           /**< absorbed inside the medium */
  double absorbed_std_error; /**< its standard error */
  double escaped[6];         /**< left the medium through each face (enum hetinv_face_id) */
  double escaped_std_error[6]; /**< their standard errors */
  double truncated;          /**< stopped by HETINV_ESTIMATOR_MAX_SCATTERING */
  uint64_t truncated_paths;  /**< photon paths stopped by HETINV_ESTIMATOR_MAX_SCATTERING (all emitters) */
} hetinv_render_stats_t;

/**
 * @brief Create an estimator with default parameters.
 * @param ctx the context; its seed and thread count are used.
 * @param[out] out receives the estimator; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_estimator_create(hetinv_context_t *ctx,
                                                   hetinv_estimator_t **out);

/** @brief Destroy an estimator and set @p *estimator to NULL; NULL is a no-op. */
HETINV_API void hetinv_estimator_destroy(hetinv_estimator_t **estimator);

/**
 * @brief Valid range of a parameter (integers are passed as doubles).
 * @param param the parameter.
 * @param[out] lo the inclusive lower bound; may be NULL.
 * @param[out] hi the inclusive upper bound; may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_OUT_OF_RANGE for an unknown parameter.
 */
HETINV_API hetinv_result_t hetinv_estimator_param_bounds(hetinv_estimator_param_t param,
                                                         double *lo, double *hi);

/**
 * @brief Set a parameter.
 * @param estimator the estimator.
 * @param param the parameter.
 * @param value within hetinv_estimator_param_bounds(); integer parameters
 *        must hold an integer.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (unknown parameter); HETINV_ERROR_INVALID_ARGUMENT (value).
 */
HETINV_API hetinv_result_t hetinv_estimator_set_param(hetinv_estimator_t *estimator,
                                                      hetinv_estimator_param_t param,
                                                      double value);

/**
 * @brief Read a parameter.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE.
 */
HETINV_API hetinv_result_t hetinv_estimator_get_param(const hetinv_estimator_t *estimator,
                                                      hetinv_estimator_param_t param,
                                                      double *value);

/**
 * @brief Render every value of a measurement set for a medium.
 * @param estimator the estimator.
 * @param medium a committed medium with the box and refractive indices the
 *        set's rows were created for. Only read.
 * @param set the measurement set (at least one row). Only read.
 * @param[out] values receives hetinv_measurements_value_count() values.
 * @param[out] std_errors receives their Monte Carlo standard errors; may be NULL.
 * @param[out] ballistic receives, per value, the unscattered part: for an
 *        orthographic pixel the power per unit area of ballistic light that
 *        leaves through the pixel exactly in the sensor's direction (the
 *        coefficient of a Dirac in direction, excluded from @p values); for
 *        a hemispherical detector the unscattered part of its value (included
 *        in @p values). May be NULL.
 * @param count size of each array; must equal the set's value count.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_STATE (medium not committed);
 *         HETINV_ERROR_INVALID_ARGUMENT (empty set, wrong count, a medium
 *         whose box or indices differ from the set's);
 *         HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_estimator_render(hetinv_estimator_t *estimator,
                                                   const hetinv_medium_t *medium,
                                                   const hetinv_measurements_t *set,
                                                   double *values, double *std_errors,
                                                   double *ballistic, size_t count);

/**
 * @brief Vector–Jacobian product of the rendered values: for every entry k
 *        of π, grad[k] = Σ_n cotangent[n] · ∂I_n/∂π_k (Eq. 20), estimated
 *        by score functions (Eqs. 17–19) on paths of the estimator's current
 *        stream. With a one-hot cotangent this is one row of the Jacobian G
 *        (never formed: the cost is a small constant times a render).
 *
 * A path's score is the sum over its segments of -ℓ_k (∂/∂σa_k and
 * ∂/∂σs_k), over its scattering vertices of 1/σs_k (∂/∂σs_k) and
 * ∂ log f_HG/∂g_k (∂/∂g_k), next-event connection segments and the
 * connection's phase included; Fresnel events and Russian roulette do not
 * depend on π. Values of orthographic sensors do not include ballistic light,
 * and neither do their gradients. Bitwise deterministic like the render.
 * @param estimator the estimator.
 * @param medium committed medium (as for hetinv_estimator_render()).
 * @param set the measurement set.
 * @param cotangent @p count finite weights, in the set's value layout.
 * @param count the set's value count.
 * @param map parameter map made for the medium's grid.
 * @param[out] grad receives hetinv_param_map_size(map) values.
 * @param[out] grad_std_errors their Monte Carlo standard errors; may be NULL.
 *        Each emitter's batch means give its variance; the emitters'
 *        variances are summed (emitters trace independent photons). Asking
 *        for them costs one pull-back through @p map per emitter and batch.
 * @param grad_count length of @p grad (and @p grad_std_errors).
 * @return as hetinv_estimator_render(), plus HETINV_ERROR_INVALID_ARGUMENT
 *         for a non-finite cotangent, a map of another grid or a wrong
 *         grad_count.
 */
HETINV_API hetinv_result_t hetinv_estimator_gradient(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const double *cotangent, size_t count, const hetinv_param_map_t *map, double *grad,
    double *grad_std_errors, size_t grad_count);

/**
 * @brief Jacobian–vector product of the rendered values: for every value n,
 *        jv[n] = Σ_k ∂I_n/∂π_k · v[k], estimated by score functions on paths
 *        of the estimator's current stream (the forward-mode companion of
 *        hetinv_estimator_gradient(), which gives Jᵀu).
 *
 * Each splat of contribution c into value n adds c·(S·v), S being the
 * path's score accumulated before the splat — the same attribution as the
 * gradient pass: the path's segments and vertices so far, and for a
 * next-event connection also its own segments and the vertex's phase
 * toward the sensor. So uᵀ(J v) and (Jᵀu)ᵀv estimate the same number.
 * The cost is about that of a render; bitwise deterministic like it.
 * @param estimator the estimator.
 * @param medium committed medium (as for hetinv_estimator_render()).
 * @param set the measurement set.
 * @param map parameter map made for the medium's grid.
 * @param v the tangent: @p v_count finite values.
 * @param v_count hetinv_param_map_size(map).
 * @param[out] jv receives @p count values, in the set's value layout.
 * @param[out] jv_std_errors their standard errors (from the batch means,
 *        as for a render); may be NULL.
 * @param count the set's value count.
 * @return as hetinv_estimator_render(), plus HETINV_ERROR_INVALID_ARGUMENT
 *         for a non-finite v, a map of another grid or a wrong v_count, and
 *         HETINV_ERROR_UNSUPPORTED for a context with several MPI ranks.
 */
HETINV_API hetinv_result_t hetinv_estimator_jvp(hetinv_estimator_t *estimator,
                                                const hetinv_medium_t *medium,
                                                const hetinv_measurements_t *set,
                                                const hetinv_param_map_t *map, const double *v,
                                                size_t v_count, double *jv, double *jv_std_errors,
                                                size_t count);

/**
 * @brief Appearance-matching loss of Eq. (9) and its stochastic gradient.
 *
 * Renders I with the estimator's stream s, forms the loss
 * Σ_n mask_n·w_n·(I_n − Ī_n)² with the set's measured values Ī, weights w
 * and mask, then estimates its gradient from independent paths of stream
 * (s + 1) mod 65536, with cotangent 2·mask·w·(I − Ī) (Eqs. 21–22).
 * With HETINV_ESTIMATOR_LOSS_CLIP c > 0 each term is Huber's instead: w·r²
 * for √w·|r| ≤ c, 2·c·√w·|r| − c² beyond, and its cotangent
 * 2·mask·w·r clipped at ±2·mask·c·√w. The clipped cotangent is a nonlinear
 * function of the render, so the gradient is that of the expected Huber
 * term only where the render's error stays within the clip.
 * With a calibration gain (hetinv_estimator_set_gain_mode()) the model is
 * k·I: the loss is min over k of Σ_n mask_n·w_n·(k_n·I_n − Ī_n)², k_n the
 * gain of value n's emitter (or the one global gain), and the cotangent
 * 2·mask·w·k·(k·I − Ī); the gains are then read with
 * hetinv_estimator_get_gains(). Masked values (mask 0) and values of
 * weight 0 enter neither the loss, nor the gradient, nor the gains.
 * @param estimator the estimator.
 * @param medium committed medium.
 * @param set the measurement set holding the measured values.
 * @param map parameter map made for the medium's grid.
 * @param[out] loss receives the loss; may be NULL.
 * @param[out] rendered receives the rendered values I (value_count; the
 *        model's, not multiplied by a gain); may be NULL.
 * @param[out] grad receives hetinv_param_map_size(map) values.
 * @param grad_count length of @p grad.
 * @return as hetinv_estimator_gradient(), plus HETINV_ERROR_OUT_OF_MEMORY
 *         for the gains.
 */
HETINV_API hetinv_result_t hetinv_estimator_loss_gradient(
    hetinv_estimator_t *estimator, const hetinv_medium_t *medium, const hetinv_measurements_t *set,
    const hetinv_param_map_t *map, double *loss, double *rendered, double *grad, size_t grad_count);

/** A calibration-gain mode: a value of enum hetinv_gain_mode_id. */
typedef int32_t hetinv_gain_mode_t;

/** How hetinv_estimator_loss_gradient() treats the instrument's unknown
 *  scale. Pinned values. */
enum hetinv_gain_mode_id {
  /** The measured values are in the model's units (the default; the loss is
   *  exactly that of Eq. 9). */
  HETINV_GAIN_NONE = 0,
  /** One unknown gain k for the whole set: the measurements are k times the
   *  model's values. */
  HETINV_GAIN_GLOBAL = 1,
  /** One unknown gain per emitter (a source whose power or coupling is not
   *  known): emitter e is the e-th distinct emitter of the set in order of
   *  its first row (hetinv_measurements_add()). */
  HETINV_GAIN_PER_EMITTER = 2
};

/**
 * @brief Estimate an unknown calibration gain jointly with the volume.
 *
 * Real measurements are often known only up to a scale: detector gain,
 * source power, fibre coupling. With a gain mode other than
 * HETINV_GAIN_NONE, hetinv_estimator_loss_gradient() scales the *model*
 * (not the measurements: the weights stay those of the measured values, and
 * the recovered volume is in the model's units) by the gain that fits best:
 * for the loss L(k) = Σ_n mask_n·w_n·(k·I_n − Ī_n)² over the values sharing
 * the gain, fitted to the expected render:
 *     k* = max(0, Σ mask·w·I·Ī / Σ mask·w·(I² − s²)),
 * in closed form at every call (variable projection), s the render's
 * batch-means standard error: a rendered I² is E[I]² plus the render's
 * variance, and I² − s² removes it (the U-statistic of the batch means,
 * unbiased for E[I]² with batches of equal size; at least 2 batches). With
 * Σ mask·w·I² instead, k* was low by about the renders' relative variance:
 * −37 % at 100 photons per emitter in the files round trip, where this fit
 * is +5 to +10 % (docs/results/gain.md). Where the corrected denominator is
 * not positive (photons so few that the render is noise) Σ mask·w·I² is
 * used; k* = 0 when no used value renders any light. A negative fit
 * (noise only) is clamped to 0, the least-squares gain among physical ones.
 *
 * The gain is fitted by least squares even under HETINV_ESTIMATOR_LOSS_CLIP;
 * the clip then applies to the residuals k*·I − Ī.
 *
 * Gradient: k* minimises the expected L(k, π), so (envelope theorem) the
 * gradient of L(k*(π), π) with respect to π is ∂L/∂π at fixed k = k*:
 * Σ_n 2·mask·w·k*·(k*·I_n − Ī_n)·∂I_n/∂π, with no term through the
 * dependence of k* on π.
 *
 * Bias: k* and the residuals come from the render of stream s, the
 * Jacobian from the independent stream s + 1, as without a gain. The
 * gradient is then unbiased for ∂L/∂π at the gain the render estimates,
 * but that gain is a ratio of noisy sums: E[k̂·(k̂·I − Ī)] differs from
 * k*·(k*·E[I] − Ī) by terms of the order of the renders' relative variance
 * (1/photons), as the loss itself (min over k of a noisy loss is biased
 * low by the same order). The bias vanishes as photons grow: on the
 * problem of the loss-gradient validation test (3 values) it is −15 % of
 * one entry at 200 photons per call and −0.6 % at 3200 (+16 % and +1.1 %
 * with the denominator Σ mask·w·I²; docs/results/gain.md). Fitting k on
 * another stream would not remove it (E[k̂²] ≠ E[k̂]²): measured, it
 * halves the bias and multiplies the gradient's variance by 3.6.
 *
 * The gains are fitted on the set passed to each call: the optimizer's
 * minibatches see only their emitters' values, so a global gain is then
 * fitted per minibatch. hetinv_estimator_render(), hetinv_estimator_gradient(),
 * hetinv_estimator_jvp() and the bound (hetinv/bound.h) ignore the mode. A
 * resumed optimizer run refuses an estimator of another mode than its
 * checkpoint's (hetinv_optimizer_resume()).
 * @param estimator the estimator.
 * @param mode HETINV_GAIN_NONE, HETINV_GAIN_GLOBAL or HETINV_GAIN_PER_EMITTER.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (mode). Gains of an earlier call are forgotten.
 */
HETINV_API hetinv_result_t hetinv_estimator_set_gain_mode(hetinv_estimator_t *estimator,
                                                          hetinv_gain_mode_t mode);

/**
 * @brief The calibration-gain mode.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_estimator_get_gain_mode(const hetinv_estimator_t *estimator,
                                                          hetinv_gain_mode_t *mode);

/**
 * @brief The gains fitted by the last successful hetinv_estimator_loss_gradient().
 *
 * Multiply a rendered value by its gain to compare it with the measured
 * value (measurement units per model unit).
 * @param estimator the estimator.
 * @param[out] gains receives the gains: one (HETINV_GAIN_GLOBAL) or one per
 *        emitter of the set of that call, in the order of
 *        HETINV_GAIN_PER_EMITTER. May be NULL when @p capacity is 0 (to ask
 *        for the count).
 * @param capacity length of @p gains.
 * @param[out] count receives the number of gains; may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_STATE (mode HETINV_GAIN_NONE, or no
 *         successful loss gradient since the mode was set);
 *         HETINV_ERROR_INVALID_ARGUMENT (@p capacity smaller than the count
 *         and not 0).
 */
HETINV_API hetinv_result_t hetinv_estimator_get_gains(const hetinv_estimator_t *estimator,
                                                      double *gains, size_t capacity,
                                                      size_t *count);

/**
 * @brief Statistics of the last successful render.
 * @param estimator the estimator.
 * @param[in,out] stats stats->size must be set; the members it covers are filled.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (size too small);
 *         HETINV_ERROR_INVALID_STATE (nothing rendered yet).
 */
HETINV_API hetinv_result_t hetinv_estimator_get_stats(const hetinv_estimator_t *estimator,
                                                      hetinv_render_stats_t *stats);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_ESTIMATOR_H */
