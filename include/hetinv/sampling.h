/**
 * @file sampling.h
 * @brief Sampling functions of a measurement (Eq. 2–3 of the paper):
 *        emitters W_i, sensors W_o and pathlength windows W_τ.
 *
 * Geometry: emitters and sensors live on the boundary of a medium's box and
 * are created from a medium, whose box and refractive indices they copy
 * (they keep no pointer to it). They may then be used to render any medium
 * with the same box and indices — for example the successive estimates of
 * an optimisation. Faces are named by enum hetinv_face_id. A point on a face
 * is given by two face coordinates (u, v): (y, z) on the x faces, (x, z) on
 * the y faces, (x, y) on the z faces, in the medium's length unit.
 *
 * Units of the values rendered (per unit emitted power):
 * - hemispherical detector: the fraction of the emitted power that leaves
 *   through its region, e.g. diffuse reflectance Rd or transmittance Tt;
 * - fiber probe: the fraction of the emitted power that leaves through its
 *   disk within its numerical aperture;
 * - orthographic pixel: outgoing radiance in the sensor's direction
 *   averaged over the pixel's area on the face (power per area per
 *   steradian);
 * - pathlength bins multiply either by the bin's window W_τ(τ), τ being the
 *   geometric length the light travelled inside the medium.
 *
 * Emitters, sensors and pathlength windows are immutable after creation and
 * may be shared between threads. They must outlive every measurement set
 * that uses them.
 */
#ifndef HETINV_SAMPLING_H
#define HETINV_SAMPLING_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/medium.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A face of the box: a value of enum hetinv_face_id. */
typedef int32_t hetinv_face_t;

/** Faces of the medium's box. Pinned values. */
enum hetinv_face_id {
  HETINV_FACE_X_MIN = 0, /**< x = box_min[0], outward normal -x; coordinates (y, z) */
  HETINV_FACE_X_MAX = 1, /**< x = box_max[0], outward normal +x; coordinates (y, z) */
  HETINV_FACE_Y_MIN = 2, /**< y = box_min[1], outward normal -y; coordinates (x, z) */
  HETINV_FACE_Y_MAX = 3, /**< y = box_max[1], outward normal +y; coordinates (x, z) */
  HETINV_FACE_Z_MIN = 4, /**< z = box_min[2], outward normal -z; coordinates (x, y) */
  HETINV_FACE_Z_MAX = 5  /**< z = box_max[2], outward normal +z; coordinates (x, y) */
};

/** Most pixels of an orthographic sensor: 2^24 (a 4096 × 4096 camera). */
#define HETINV_MAX_SENSOR_PIXELS (INT32_C(1) << 24)
/** Most cells of an area emitter's pattern: 2^24 (4096 × 4096). */
#define HETINV_MAX_PATTERN_CELLS (INT32_C(1) << 24)
/** Most ideal sources of a combination emitter: 2^20. */
#define HETINV_MAX_COMBINATION_SOURCES (INT32_C(1) << 20)
/** Most bins of a pathlength sampling function: 65536. */
#define HETINV_MAX_PATHLENGTH_BINS 65536

/** Opaque emitter handle (W_i). */
typedef struct hetinv_emitter hetinv_emitter_t;
/** Opaque sensor handle (W_o). */
typedef struct hetinv_sensor hetinv_sensor_t;
/** Opaque pathlength sampling function handle (W_τ). */
typedef struct hetinv_pathlength hetinv_pathlength_t;

/* ------------------------------------------------------------------------ */
/** @name Emitters
 * Every emitter emits a total power of 1 from outside the medium, unless a
 * combination's weights say otherwise. Light refracts into the medium with
 * Fresnel transmittance; the part reflected at the first surface (the
 * specular reflection) never enters and is in no rendered value: see
 * hetinv_render_stats_t::specular.
 * @{ */

/**
 * @brief Ideal source (Eq. 4): a collimated pencil beam.
 * @param medium gives the box and refractive indices; only read.
 * @param origin a point outside the box or on its boundary. Read during the call.
 * @param direction travel direction (need not be unit length; not zero).
 *        The ray from @p origin must enter the box. Read during the call.
 * @param[out] out receives the emitter; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (non-finite or zero vector, origin
 *         strictly inside the box, a ray that misses the box or only grazes
 *         it); HETINV_ERROR_OUT_OF_MEMORY. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_emitter_create_ideal(const hetinv_medium_t *medium,
                                                       const double origin[3],
                                                       const double direction[3],
                                                       hetinv_emitter_t **out);

/**
 * @brief Collimated area source on a face with a spatial pattern.
 * @param medium gives the box and refractive indices; only read.
 * @param face the lit face.
 * @param direction travel direction, pointing into the face.
 * @param rect_min face coordinates (u, v) of the lit rectangle's lower
 *        corner, inside the face, rect_min[i] < rect_max[i].
 * @param rect_max its upper corner, inside the face.
 * @param pattern_width pattern cells per row (> 0).
 * @param pattern_height pattern rows (> 0; pattern_width·pattern_height at
 *        most HETINV_MAX_PATTERN_CELLS); the pattern covers the rectangle,
 *        row 0 at v = rect_min[1].
 * @param pattern pattern_width·pattern_height weights ≥ 0, not all zero,
 *        u fastest; NULL for a uniform rectangle. Copied.
 *        The emitted power (1) is spread over the rectangle in proportion
 *        to the weights.
 * @param[out] out receives the emitter; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_RANGE (face); HETINV_ERROR_INVALID_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_MEMORY. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_emitter_create_area(
    const hetinv_medium_t *medium, hetinv_face_t face, const double direction[3],
    const double rect_min[2], const double rect_max[2], int32_t pattern_width,
    int32_t pattern_height, const double *pattern, hetinv_emitter_t **out);

/**
 * @brief Diffuse point source: a point on a face emitting from outside with
 *        equal radiance in every inward direction (a Lambertian, cosine-
 *        weighted distribution of power).
 * @param medium gives the box and refractive indices; only read.
 * @param face the face the point lies on.
 * @param point face coordinates (u, v) inside the face.
 * @param[out] out receives the emitter; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_RANGE (face); HETINV_ERROR_INVALID_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_MEMORY. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_emitter_create_diffuse(const hetinv_medium_t *medium,
                                                         hetinv_face_t face,
                                                         const double point[2],
                                                         hetinv_emitter_t **out);

/**
 * @brief Weighted combination of ideal sources; it emits a total power equal
 *        to the sum of the weights.
 * @param medium gives the box and refractive indices; only read.
 * @param count number of ideal sources, in [1, HETINV_MAX_COMBINATION_SOURCES].
 * @param origins 3·count coordinates, as for hetinv_emitter_create_ideal().
 * @param directions 3·count components.
 * @param weights count powers ≥ 0, not all zero.
 * @param[out] out receives the emitter; NULL on failure.
 * @return as hetinv_emitter_create_ideal(); the message names the source index.
 */
HETINV_API hetinv_result_t hetinv_emitter_create_combination(const hetinv_medium_t *medium,
                                                             int32_t count, const double *origins,
                                                             const double *directions,
                                                             const double *weights,
                                                             hetinv_emitter_t **out);

/** @brief Destroy an emitter and set @p *emitter to NULL; NULL is a no-op. */
HETINV_API void hetinv_emitter_destroy(hetinv_emitter_t **emitter);
/** @} */

/* ------------------------------------------------------------------------ */
/** @name Sensors
 * @{ */

/**
 * @brief Orthographic pixel grid on a face, seeing light that leaves the
 *        face in one direction (the practical ideal sensor element of Eq. 5,
 *        with a finite pixel area).
 *
 * Pixel (i, j), value index j·width + i, covers face coordinates
 * [origin[0] + i·pixel_size[0], +pixel_size[0]] × [origin[1] + j·pixel_size[1], +pixel_size[1]].
 * Pixels may extend beyond the face; only light leaving the face counts.
 * Unscattered (ballistic) light is a Dirac in direction at such a sensor and
 * is reported in the separate ballistic channel of the render, never in the
 * values. From a diffuse source, whose unscattered light reaches the face
 * in a spread of directions, it is not estimated at all (light tracing has
 * no scattering vertex to connect from): such a sensor sees scattered light
 * only.
 * @param medium gives the box and refractive indices; only read.
 * @param face the face the sensor looks at.
 * @param direction direction of the light leaving the face toward the
 *        sensor (pointing away from the medium; any angle, not only the
 *        normal).
 * @param origin face coordinates of pixel (0, 0)'s lower corner.
 * @param pixel_size pixel extent along u and v, each > 0.
 * @param width pixels per row, > 0.
 * @param height rows of pixels, > 0; width·height at most
 *        HETINV_MAX_SENSOR_PIXELS.
 * @param[out] out receives the sensor; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (face); HETINV_ERROR_INVALID_ARGUMENT (a direction pointing into the
 *         medium or along the face, one no light from inside can take
 *         because η < η_out, non-finite values, non-positive sizes, more
 *         than HETINV_MAX_SENSOR_PIXELS pixels); HETINV_ERROR_OUT_OF_MEMORY.
 *         Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_sensor_create_orthographic(
    const hetinv_medium_t *medium, hetinv_face_t face, const double direction[3],
    const double origin[2], const double pixel_size[2], int32_t width, int32_t height,
    hetinv_sensor_t **out);

/**
 * @brief Hemispherical (flux) detector: all power leaving the box through a
 *        rectangle of a face, in any direction, unscattered light included.
 *        One value.
 * @param medium gives the box and refractive indices; only read.
 * @param face the face.
 * @param rect_min face coordinates of the rectangle's lower corner; NULL,
 *        with rect_max NULL, for the whole face.
 * @param rect_max its upper corner; NULL with rect_min.
 * @param[out] out receives the sensor; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE;
 *         HETINV_ERROR_INVALID_ARGUMENT (empty or non-finite rectangle, only
 *         one of the two given); HETINV_ERROR_OUT_OF_MEMORY. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_sensor_create_hemispherical(const hetinv_medium_t *medium,
                                                              hetinv_face_t face,
                                                              const double rect_min[2],
                                                              const double rect_max[2],
                                                              hetinv_sensor_t **out);

/**
 * @brief Fiber probe: the power leaving the box through a disk on a face
 *        within a numerical aperture, unscattered light included. One value.
 *
 * Light leaving through the disk at face coordinates within @p radius of
 * @p centre counts if its direction outside the medium makes an angle θ
 * with the face's outward normal such that η_out·sin θ ≤ NA, η_out being
 * the medium's outside index (hetinv_medium_set_ior()). An NA of at least
 * η_out accepts every direction: the fiber is then a hemispherical
 * detector over the disk. The disk may extend beyond the face; only light
 * leaving the face counts. The fiber is ideal: it does not reflect or
 * block light, and its own core index plays no part (NA is the fiber's,
 * as a datasheet gives it: n·sin θ_max in any medium).
 * @param medium gives the box and refractive indices; only read.
 * @param face the face the fiber's end lies on.
 * @param centre face coordinates (u, v) of the disk's centre, on the face
 *        (within its closed extent). Read during the call.
 * @param radius the disk's radius (the core's), finite and > 0.
 * @param numerical_aperture NA, finite and > 0.
 * @param[out] out receives the sensor; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (face); HETINV_ERROR_INVALID_ARGUMENT (a centre off the face, a
 *         radius or NA that is not finite and > 0); HETINV_ERROR_OUT_OF_MEMORY.
 *         Thread-safe. Added in 0.3.
 */
HETINV_API hetinv_result_t hetinv_sensor_create_fiber(const hetinv_medium_t *medium, hetinv_face_t face,
                                                      const double centre[2], double radius,
                                                      double numerical_aperture, hetinv_sensor_t **out);

/** @brief Number of values (pixels) of a sensor; 0 for NULL. */
HETINV_API int32_t hetinv_sensor_pixel_count(const hetinv_sensor_t *sensor);

/**
 * @brief Width and height of a sensor's pixel grid (1 × 1 for a
 *        hemispherical detector or a fiber probe). Either output may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT if @p sensor is NULL.
 */
HETINV_API hetinv_result_t hetinv_sensor_get_size(const hetinv_sensor_t *sensor, int32_t *width,
                                                  int32_t *height);

/** @brief Destroy a sensor and set @p *sensor to NULL; NULL is a no-op. */
HETINV_API void hetinv_sensor_destroy(hetinv_sensor_t **sensor);
/** @} */

/* ------------------------------------------------------------------------ */
/** @name Pathlength sampling functions
 * @{ */

/** Window shape of pathlength bins: a value of enum hetinv_window_id. */
typedef int32_t hetinv_window_t;

/** Pathlength window shapes. Pinned values. */
enum hetinv_window_id {
  /** W_τ = 1 on [centre - width/2, centre + width/2), else 0: adjacent
   *  bins whose widths equal their spacing partition the pathlengths. */
  HETINV_WINDOW_BOX = 0,
  /** W_τ = exp(-(τ - centre)² / (2 width²)), peak 1; width is the standard deviation. */
  HETINV_WINDOW_GAUSSIAN = 1
};

/**
 * @brief Steady state: W_τ = 1 for every pathlength (one bin).
 * @param ctx the context.
 * @param[out] out receives the handle; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_pathlength_create_steady(hetinv_context_t *ctx,
                                                           hetinv_pathlength_t **out);

/**
 * @brief A set of pathlength bins (pathlength decomposition / transient imaging).
 * @param ctx the context.
 * @param window HETINV_WINDOW_BOX or HETINV_WINDOW_GAUSSIAN.
 * @param count number of bins, in [1, HETINV_MAX_PATHLENGTH_BINS].
 * @param centres count finite bin centres ≥ 0 (geometric length inside the
 *        medium). Copied.
 * @param width bin width (box) or standard deviation (Gaussian), finite and > 0.
 * @param[out] out receives the handle; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE
 *         (window); HETINV_ERROR_INVALID_ARGUMENT (count, centres, width);
 *         HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_pathlength_create_bins(hetinv_context_t *ctx,
                                                         hetinv_window_t window, int32_t count,
                                                         const double *centres, double width,
                                                         hetinv_pathlength_t **out);

/** Most samples of an instrument response function: 65536. */
#define HETINV_MAX_IRF_SAMPLES 65536

/** Speed of light in vacuum, c₀, in millimetres per picosecond. */
#define HETINV_SPEED_OF_LIGHT_MM_PER_PS 0.299792458

/**
 * @brief Pathlength bins seen through an instrument response function (IRF),
 *        for time-resolved data.
 *
 * A real detector smears the arrival time of the light: the measured
 * transient is the true one convolved with the instrument's response h. The
 * IRF is given as samples h_j at pathlength offsets d_j (convert a time axis
 * with hetinv_irf_offsets_from_times()); the samples are normalised to sum 1
 * (an IRF redistributes light in time, it does not scale it: an unknown
 * scale is the calibration gain, see hetinv_estimator_set_gain_mode()). A
 * photon of pathlength τ is seen at τ + d_j with weight h_j, so bin b's
 * window becomes
 *     W'_b(τ) = Σ_j h_j · W_b(τ + d_j),
 * the convolution of the bin's window with the IRF, applied to each path as
 * it is scored. This is exact for any offsets (they need not be multiples of
 * the bin spacing, nor the bins evenly spaced), it sees light from
 * pathlengths outside the bins' own range (which a convolution of the
 * rendered bins would miss at the edges), and the forward, gradient,
 * tangent (J·v) and Fisher passes all use the same windows, so the
 * gradient is that of the convolved values with no extra step. A positive
 * offset delays: the IRF of a detector that reports light late has its
 * mass at d > 0. Samples of zero are dropped; a single sample (a delta)
 * at offset 0 gives exactly, bit for bit, the values of
 * hetinv_pathlength_create_bins(). Scoring costs one bin search per kept
 * sample: an IRF of J non-zero samples makes every splat about J times as
 * expensive (subsample a finely sampled IRF to the bin width or so).
 * @param ctx the context.
 * @param window as for hetinv_pathlength_create_bins().
 * @param count as for hetinv_pathlength_create_bins().
 * @param centres as for hetinv_pathlength_create_bins().
 * @param width as for hetinv_pathlength_create_bins().
 * @param irf_count number of IRF samples, in [1, HETINV_MAX_IRF_SAMPLES].
 * @param irf_offsets irf_count finite pathlength offsets d_j (the medium's
 *        length unit; any sign, any order). Copied.
 * @param irf_samples irf_count finite samples h_j ≥ 0 with a finite sum
 *        > 0 (clip a background-subtracted IRF at 0). Copied.
 * @param[out] out receives the handle; NULL on failure.
 * @return as hetinv_pathlength_create_bins(), plus
 *         HETINV_ERROR_INVALID_ARGUMENT naming the IRF sample or the sum.
 */
HETINV_API hetinv_result_t hetinv_pathlength_create_bins_irf(
    hetinv_context_t *ctx, hetinv_window_t window, int32_t count, const double *centres,
    double width, int32_t irf_count, const double *irf_offsets, const double *irf_samples,
    hetinv_pathlength_t **out);

/**
 * @brief Converts times of flight in picoseconds into pathlengths inside the
 *        medium: τ = c₀·t / η, in the medium's length unit.
 *
 * For an IRF's time axis (offsets of hetinv_pathlength_create_bins_irf()),
 * and equally for bin centres and widths given in time. c₀ is
 * HETINV_SPEED_OF_LIGHT_MM_PER_PS; η is the medium's refractive index (the
 * group index for a dispersive medium); @p length_unit_mm says how long the
 * medium's length unit is: 1 if the medium's coordinates are millimetres,
 * 10 for centimetres, 1000 for metres. Thread-safe; needs no context.
 * @param times_ps @p count finite times in picoseconds (any sign).
 * @param count number of times; 0 does nothing.
 * @param eta refractive index, finite and ≥ 1.
 * @param length_unit_mm length of the medium's unit in mm, finite and > 0.
 * @param[out] pathlengths receives @p count values; may be @p times_ps itself.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_INVALID_ARGUMENT
 *         (eta, unit, a non-finite time or result, named by its index).
 *         Nothing is written on failure.
 */
HETINV_API hetinv_result_t hetinv_irf_offsets_from_times(const double *times_ps, size_t count,
                                                         double eta, double length_unit_mm,
                                                         double *pathlengths);

/** @brief Number of bins (1 for steady state); 0 for NULL. */
HETINV_API int32_t hetinv_pathlength_bin_count(const hetinv_pathlength_t *pathlength);

/** @brief Destroy and set @p *pathlength to NULL; NULL is a no-op. */
HETINV_API void hetinv_pathlength_destroy(hetinv_pathlength_t **pathlength);
/** @} */

#ifdef __cplusplus
}
#endif

#endif /* HETINV_SAMPLING_H */
