/**
 * @file medium.h
 * @brief The medium: an axis-aligned box of voxels with piecewise-constant
 *        absorption σa, scattering σs and Henyey–Greenstein anisotropy g,
 *        and a refractive index inside and outside.
 *
 * Conventions (used everywhere in libhetinv):
 * - Lengths in any consistent unit (millimetres by default); σa and σs are
 *   per unit length.
 * - The box [box_min, box_max] is split into nx × ny × nz equal voxels.
 *   Voxel (ix, iy, iz) has linear index ix + nx * (iy + ny * iz): x varies
 *   fastest, as in Mitsuba's .vol files. A grid with nz = 1 spanning the box
 *   depth is the "2D cross-section, constant along z" case.
 * - A new medium holds σa = σs = g = 0, η = η_out = 1.
 *
 * Life cycle: create, set values (every value is validated as it is set),
 * then hetinv_medium_commit(). A committed medium is immutable: setters
 * return HETINV_ERROR_INVALID_STATE, and any number of threads may read it
 * and render with it at once. Before commit a medium belongs to one thread.
 * To change a committed medium, hetinv_medium_clone() it.
 */
#ifndef HETINV_MEDIUM_H
#define HETINV_MEDIUM_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Opaque medium handle. */
typedef struct hetinv_medium hetinv_medium_t;

/** Identifies one per-voxel parameter: a value of enum hetinv_param_id. */
typedef int32_t hetinv_param_t;

/** Per-voxel parameters. Pinned values. */
enum hetinv_param_id {
  HETINV_PARAM_SIGMA_A = 0, /**< absorption coefficient σa >= 0 */
  HETINV_PARAM_SIGMA_S = 1, /**< scattering coefficient σs >= 0 */
  HETINV_PARAM_G = 2,       /**< Henyey–Greenstein anisotropy, -1 < g < 1 */
  HETINV_PARAM_COUNT = 3    /**< number of per-voxel parameters */
};

/**
 * @brief Static name of a parameter ("sigma_a", "sigma_s", "g"), or
 *        "unknown" for any other value. Thread-safe.
 */
HETINV_API const char *hetinv_param_name(hetinv_param_t param);

/**
 * Most voxels of a medium: 2^24 (256³). The medium holds 24 bytes per voxel,
 * a render's transport grid as much again, and a gradient 24 bytes per
 * voxel and thread, so this keeps a medium and its renders within a few GB.
 */
#define HETINV_MAX_VOXELS (INT32_C(1) << 24)

/**
 * @brief Create a medium filling the box [box_min, box_max] with a grid of
 *        dims[0] × dims[1] × dims[2] voxels.
 * @param ctx the context; the medium must be destroyed before it.
 * @param box_min the lower corner; every coordinate finite and
 *        box_min[i] < box_max[i]. Read during the call only.
 * @param box_max the upper corner, likewise.
 * @param dims voxel counts, each > 0, whose product is at most
 *        HETINV_MAX_VOXELS. Read during the call only.
 * @param[out] out receives the medium (uncommitted); NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (degenerate or non-finite box,
 *         dimension <= 0, more than HETINV_MAX_VOXELS voxels);
 *         HETINV_ERROR_OUT_OF_MEMORY.
 * Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_medium_create(hetinv_context_t *ctx, const double box_min[3],
                                                const double box_max[3], const int32_t dims[3],
                                                hetinv_medium_t **out);

/**
 * @brief Create an uncommitted copy of @p src (grid, values, indices) from
 *        the same context.
 * @param src any medium, committed or not; only read.
 * @param[out] out receives the copy; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_MEMORY.
 * Thread-safe if @p src is committed.
 */
HETINV_API hetinv_result_t hetinv_medium_clone(const hetinv_medium_t *src, hetinv_medium_t **out);

/**
 * @brief Destroy a medium and set @p *medium to NULL. NULL or a NULL handle
 *        is a no-op. No other thread may be using the medium.
 */
HETINV_API void hetinv_medium_destroy(hetinv_medium_t **medium);

/** The largest relative index eta / eta_out (or its inverse) a boundary
 *  may have; every dielectric lies far inside it, and Fresnel's arithmetic
 *  (which squares it) stays exact. */
#define HETINV_MAX_RELATIVE_IOR 1e3

/**
 * @brief Set the refractive index inside (@p eta) and outside (@p eta_out).
 *        Equal values make the boundary index-matched (invisible).
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT unless both are finite and > 0 and
 *         eta / eta_out lies within [1 / HETINV_MAX_RELATIVE_IOR,
 *         HETINV_MAX_RELATIVE_IOR];
 *         HETINV_ERROR_INVALID_STATE if committed.
 */
HETINV_API hetinv_result_t hetinv_medium_set_ior(hetinv_medium_t *medium, double eta,
                                                 double eta_out);

/**
 * @brief Give every voxel the same σa, σs and g.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (non-finite, σ < 0, |g| >= 1);
 *         HETINV_ERROR_INVALID_STATE if committed. Nothing changes on failure.
 */
HETINV_API hetinv_result_t hetinv_medium_fill(hetinv_medium_t *medium, double sigma_a,
                                              double sigma_s, double g);

/**
 * @brief Set σa, σs and g of voxel (ix, iy, iz).
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_RANGE if the voxel is outside the grid;
 *         HETINV_ERROR_INVALID_ARGUMENT; HETINV_ERROR_INVALID_STATE.
 *         Nothing changes on failure.
 */
HETINV_API hetinv_result_t hetinv_medium_set_voxel(hetinv_medium_t *medium, int32_t ix,
                                                   int32_t iy, int32_t iz, double sigma_a,
                                                   double sigma_s, double g);

/**
 * @brief Set one parameter of every voxel from an array in linear voxel order.
 * @param medium uncommitted medium.
 * @param param which parameter (enum hetinv_param_id).
 * @param values @p count values, read during the call only.
 * @param count must equal hetinv_medium_voxel_count().
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_RANGE for an unknown @p param;
 *         HETINV_ERROR_INVALID_ARGUMENT for a wrong @p count or an invalid
 *         value (the message names the first offending voxel);
 *         HETINV_ERROR_INVALID_STATE. Nothing changes on failure.
 */
HETINV_API hetinv_result_t hetinv_medium_set_grid(hetinv_medium_t *medium, hetinv_param_t param,
                                                  const double *values, size_t count);

/**
 * @brief Freeze the medium: from now on it is immutable and may be shared
 *        between threads. Committing twice is allowed and does nothing.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_medium_commit(hetinv_medium_t *medium);

/** @brief 1 if committed, 0 if not or if @p medium is NULL. */
HETINV_API int hetinv_medium_is_committed(const hetinv_medium_t *medium);

/** @brief Context the medium was created from; NULL for a NULL medium. */
HETINV_API hetinv_context_t *hetinv_medium_context(const hetinv_medium_t *medium);

/**
 * @brief Grid size: writes nx, ny, nz to @p dims.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_medium_get_dims(const hetinv_medium_t *medium, int32_t dims[3]);

/** @brief Number of voxels nx·ny·nz; 0 for a NULL medium. */
HETINV_API size_t hetinv_medium_voxel_count(const hetinv_medium_t *medium);

/**
 * @brief Box corners. Either output may be NULL if not wanted.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT if @p medium is NULL.
 */
HETINV_API hetinv_result_t hetinv_medium_get_box(const hetinv_medium_t *medium, double box_min[3],
                                                 double box_max[3]);

/**
 * @brief Refractive indices. Either output may be NULL if not wanted.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT if @p medium is NULL.
 */
HETINV_API hetinv_result_t hetinv_medium_get_ior(const hetinv_medium_t *medium, double *eta,
                                                 double *eta_out);

/**
 * @brief σa, σs and g of voxel (ix, iy, iz). Outputs may be NULL if not wanted.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_OUT_OF_RANGE if the voxel is outside the grid.
 */
HETINV_API hetinv_result_t hetinv_medium_get_voxel(const hetinv_medium_t *medium, int32_t ix,
                                                   int32_t iy, int32_t iz, double *sigma_a,
                                                   double *sigma_s, double *g);

/**
 * @brief Read-only view of one parameter's values in linear voxel order
 *        (hetinv_medium_voxel_count() doubles), valid until the medium is
 *        modified or destroyed. NULL for a NULL medium or an unknown @p param.
 */
HETINV_API const double *hetinv_medium_grid(const hetinv_medium_t *medium, hetinv_param_t param);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_MEDIUM_H */
