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
 * summed in batches reduced in a fixed order, so results are bitwise
 * identical whatever the number of threads. The batches also give each
 * value's standard error (from the spread of batch means).
 *
 * An estimator belongs to one thread at a time; it runs its own parallel
 * loop with the context's thread count.
 */
#ifndef HETINV_ESTIMATOR_H
#define HETINV_ESTIMATOR_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/measurement.h"
#include "hetinv/medium.h"
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
  /** Photons traced per emitter (default 100000; an integer ≥ 1). */
  HETINV_ESTIMATOR_PHOTONS = 0,
  /** Batches the photons of each emitter are split into, for standard errors
   *  and parallel work (default 64; integer in [2, 65536]; capped at the
   *  photon count). Changing it changes the result's rounding, not its
   *  expectation. */
  HETINV_ESTIMATOR_BATCHES = 1,
  /** Russian roulette starts when a photon's weight falls below this
   *  (default 1e-4; [0, 1]; 0 disables roulette). */
  HETINV_ESTIMATOR_ROULETTE_WEIGHT = 2,
  /** Probability that a photon survives a roulette (default 0.1; (0, 1]). */
  HETINV_ESTIMATOR_ROULETTE_SURVIVAL = 3,
  /** Only light scattered at least this many times contributes (default 0). */
  HETINV_ESTIMATOR_MIN_SCATTERING = 4,
  /** Only light scattered at most this many times contributes; photons stop
   *  after it (default 0 = unlimited). MIN = MAX = 1 gives single scattering. */
  HETINV_ESTIMATOR_MAX_SCATTERING = 5,
  /** Random stream id (default 0; integer in [0, 65535]): renders with
   *  different streams are independent, with the same stream identical. */
  HETINV_ESTIMATOR_STREAM = 6,
  HETINV_ESTIMATOR_PARAM_COUNT_ = 7 /**< not a parameter: one past the last */
};

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
 * @param[out] lo, hi the inclusive bounds; may be NULL.
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
