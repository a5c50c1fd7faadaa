/**
 * @file measurement.h
 * @brief A measurement set: the rows of Eq. (9) of the paper.
 *
 * A row is an (emitter, sensor, pathlength) triple. It yields
 * pixels × bins values, laid out bin-major: value (pixel p, bin b) of row r
 * is at index offset(r) + b·pixels + p of the set's value arrays, so one
 * bin of an orthographic sensor is a contiguous image. Rows that share an
 * emitter are rendered from the same photons. Spatial probing (a different
 * emitter per pixel or per small group of pixels) is a set of rows, each
 * with its own emitter and a small sensor.
 *
 * Besides its layout a set holds the measured values (with optional
 * standard errors), optional per-value weights (default 1) and a mask
 * (default: every value used), which the optimizer's loss uses.
 *
 * All rows must have been created from media with the same box and
 * refractive indices; a set is rendered with any medium that has them.
 * A set belongs to one thread while it is modified; once filled it may be
 * read (rendered) by several threads at once. Emitters, sensors and
 * pathlengths must outlive the sets that use them.
 */
#ifndef HETINV_MEASUREMENT_H
#define HETINV_MEASUREMENT_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/result.h"
#include "hetinv/sampling.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Most rows of a measurement set: 2^20. */
#define HETINV_MAX_MEASUREMENT_ROWS (INT32_C(1) << 20)
/** Most values (pixels × bins over all rows) of a measurement set: 2^26.
 *  A set holds 25 bytes per value and a render allocates about 32 more (plus
 *  8 per value and thread), so a full set needs a few GB. */
#define HETINV_MAX_MEASUREMENT_VALUES (INT64_C(1) << 26)

/** Opaque measurement set handle. */
typedef struct hetinv_measurements hetinv_measurements_t;

/**
 * @brief Create an empty measurement set.
 * @param ctx the context; the set must be destroyed before it.
 * @param[out] out receives the set; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_measurements_create(hetinv_context_t *ctx,
                                                      hetinv_measurements_t **out);

/** @brief Destroy a set and set @p *set to NULL; NULL is a no-op. */
HETINV_API void hetinv_measurements_destroy(hetinv_measurements_t **set);

/**
 * @brief Append a row. Its values start at 0 with weight 1, unmasked.
 * @param set the set.
 * @param emitter the row's emitter; borrowed: it must outlive the set.
 * @param sensor the row's sensor; borrowed likewise.
 * @param pathlength the row's pathlength window; borrowed likewise.
 * @param[out] row receives the row's index; may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT if the emitter or sensor was created
 *         from a medium whose box or refractive indices differ from those of
 *         the set's earlier rows (a set must not mix media), or if the set
 *         would have more than HETINV_MAX_MEASUREMENT_ROWS rows or
 *         HETINV_MAX_MEASUREMENT_VALUES values; HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_measurements_add(hetinv_measurements_t *set,
                                                   const hetinv_emitter_t *emitter,
                                                   const hetinv_sensor_t *sensor,
                                                   const hetinv_pathlength_t *pathlength,
                                                   int32_t *row);

/** @brief Number of rows; 0 for NULL. */
HETINV_API int32_t hetinv_measurements_row_count(const hetinv_measurements_t *set);

/** @brief Number of values of all rows; 0 for NULL. */
HETINV_API size_t hetinv_measurements_value_count(const hetinv_measurements_t *set);

/**
 * @brief Where a row's values are. Outputs may be NULL.
 * @param set the set.
 * @param row row index.
 * @param[out] offset index of the row's first value.
 * @param[out] pixels the sensor's pixel count.
 * @param[out] bins the pathlength's bin count (1 for steady state).
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE.
 */
HETINV_API hetinv_result_t hetinv_measurements_row_layout(const hetinv_measurements_t *set,
                                                          int32_t row, size_t *offset,
                                                          int32_t *pixels, int32_t *bins);

/**
 * @brief Set the measured values, and optionally their standard errors.
 * @param set the set.
 * @param values @p count finite values. Copied.
 * @param std_errors @p count finite values ≥ 0, or NULL (errors set to 0). Copied.
 * @param count must equal hetinv_measurements_value_count().
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (count; a non-finite value, named by
 *         its row, pixel and bin). Nothing changes on failure.
 */
HETINV_API hetinv_result_t hetinv_measurements_set_values(hetinv_measurements_t *set,
                                                          const double *values,
                                                          const double *std_errors, size_t count);

/**
 * @brief Set per-value weights of the loss (e.g. 1/variance).
 * @param set the set.
 * @param weights @p count finite values ≥ 0. Copied.
 * @param count must equal hetinv_measurements_value_count().
 * @return as hetinv_measurements_set_values().
 */
HETINV_API hetinv_result_t hetinv_measurements_set_weights(hetinv_measurements_t *set,
                                                           const double *weights, size_t count);

/**
 * @brief Set per-value scales of HETINV_ESTIMATOR_LOSS_CLIP (default 1),
 *        one for each side of the residual.
 *
 * Huber's clip c of a value of weight w and residual r = I − Ī then starts
 * at r = −c·below/√w under the data and at r = c·above/√w over it, instead
 * of ∓c/√w. Use it to count c in standard errors of the residual rather
 * than of the data: a model rendered with fewer photons than the data
 * adds its own Monte Carlo variance v_model to the residual's, and
 * s = sqrt(1 + w·v_model) (w = 1/variance) keeps the clip from cutting the
 * render's own noise. That noise is skewed: a dim value is usually a
 * little low and now and then far too high, so a clip that cuts it cuts
 * the side above the data and biases the gradient toward brighter
 * renders. The data's own rare bright paths fall on the other side, below:
 * setting s above and 1 below keeps them clipped at c of the data's
 * errors. The cut tail is also the gradient's largest noise, so a wider
 * clip trades variance for bias: it helped where the data held the
 * unknowns loosely and hurt where they held them tightly (the repository's
 * Fig. 4 experiment). Without HETINV_ESTIMATOR_LOSS_CLIP the scales
 * change nothing.
 * @param set the set.
 * @param below @p count finite values > 0 for residuals below the data
 *        (r < 0), or NULL for 1. Copied.
 * @param above the same for residuals above it (r > 0), or NULL for 1.
 * @param count must equal hetinv_measurements_value_count().
 * @return as hetinv_measurements_set_values() (a bad value is named by its
 *         array, "below" or "above").
 */
HETINV_API hetinv_result_t hetinv_measurements_set_clip_scales(hetinv_measurements_t *set, const double *below,
                                                               const double *above, size_t count);

/**
 * @brief Set the mask: values whose mask byte is 0 are left out of the loss.
 * @param set the set.
 * @param mask @p count bytes. Copied.
 * @param count must equal hetinv_measurements_value_count().
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_INVALID_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_measurements_set_mask(hetinv_measurements_t *set,
                                                        const uint8_t *mask, size_t count);

/**
 * @brief Mask out saturated values: every value whose measured value is at
 *        or above @p level gets mask byte 0 (left out of the loss, its
 *        gradient and a calibration gain); the other mask bytes are kept.
 *
 * For a detector that clips at its full well or ADC maximum, pass that
 * level after hetinv_measurements_set_values(); for dead or hot pixels
 * build a mask and use hetinv_measurements_set_mask() (a masked value may
 * hold any finite number, e.g. 0). A weight of 0 has the same effect as a
 * mask byte of 0 on the loss. The mask is ANDed: call it again after
 * setting new values to mask those too.
 * @param set the set.
 * @param level the saturation level, not NaN (+inf masks nothing).
 * @param[out] masked receives the number of values at or above @p level
 *        (whether or not they were masked already); may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (level NaN). Nothing changes on failure.
 */
HETINV_API hetinv_result_t hetinv_measurements_mask_saturated(hetinv_measurements_t *set,
                                                              double level, size_t *masked);

/** @brief Measured values (value_count), owned by the set; NULL for NULL or an empty set.
 *  Valid until the next hetinv_measurements_add() (which moves every array of
 *  the set) or the set's destruction; the setters copy into it. So are the
 *  arrays of the five functions below. */
HETINV_API const double *hetinv_measurements_values(const hetinv_measurements_t *set);
/** @brief Standard errors of the measured values, like hetinv_measurements_values(). */
HETINV_API const double *hetinv_measurements_std_errors(const hetinv_measurements_t *set);
/** @brief Weights, like hetinv_measurements_values(). */
HETINV_API const double *hetinv_measurements_weights(const hetinv_measurements_t *set);
/** @brief Scales of the loss's clip below the data (all 1 unless set), like hetinv_measurements_values(). */
HETINV_API const double *hetinv_measurements_clip_scales_below(const hetinv_measurements_t *set);
/** @brief Scales of the loss's clip above the data, like hetinv_measurements_clip_scales_below(). */
HETINV_API const double *hetinv_measurements_clip_scales_above(const hetinv_measurements_t *set);
/** @brief Mask bytes, like hetinv_measurements_values(). */
HETINV_API const uint8_t *hetinv_measurements_mask(const hetinv_measurements_t *set);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_MEASUREMENT_H */
