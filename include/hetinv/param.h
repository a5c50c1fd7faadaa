/**
 * @file param.h
 * @brief Parameter maps: the vector π an optimiser works on, and how it
 *        maps onto a medium's voxels.
 *
 * A map says which of σa, σs and g are free (the others keep the values of
 * the medium they are applied to) and how each free parameter's block of π
 * spreads over the voxel grid:
 * - identity: one value per voxel;
 * - coarse: a coarser grid, trilinearly interpolated (cell-centred, clamped
 *   at the edges) onto the medium's grid — multi-resolution optimisation;
 * - broadcast: the grid with one axis collapsed, each value copied along
 *   that axis — the paper's 2D cross-section case.
 *
 * π is laid out parameter-major: the block of the first free parameter (in
 * the order σa, σs, g), then the next; inside a block, cells in linear order
 * (x fastest). Gradients with respect to π are the pull-back of voxel
 * gradients through the map (the chain rule), see hetinv_param_map_pullback().
 * A map is immutable after creation and may be shared between threads.
 */
#ifndef HETINV_PARAM_H
#define HETINV_PARAM_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/medium.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Opaque parameter-map handle. */
typedef struct hetinv_param_map hetinv_param_map_t;

/** Bit of a free parameter in a mask: (1u << HETINV_PARAM_SIGMA_A), ... */
#define HETINV_FREE(param) (1u << (param))
/** All three parameters free. */
#define HETINV_FREE_ALL (HETINV_FREE(HETINV_PARAM_SIGMA_A) | HETINV_FREE(HETINV_PARAM_SIGMA_S) | HETINV_FREE(HETINV_PARAM_G))

/**
 * @brief One value per voxel for each free parameter.
 * @param medium gives the grid; only read.
 * @param free_mask non-empty combination of HETINV_FREE() bits.
 * @param[out] out receives the map; NULL on failure.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (empty or unknown bits);
 *         HETINV_ERROR_SIZE_OVERFLOW; HETINV_ERROR_OUT_OF_MEMORY.
 */
HETINV_API hetinv_result_t hetinv_param_map_create_identity(const hetinv_medium_t *medium,
                                                            uint32_t free_mask,
                                                            hetinv_param_map_t **out);

/**
 * @brief A coarse grid of coarse_dims cells per axis, interpolated trilinearly
 *        onto the medium's grid (cell centres aligned with the box; values
 *        clamped at the outermost centres).
 * @param medium gives the grid; only read.
 * @param coarse_dims cells per axis, each in [1, the medium's count].
 * @param free_mask non-empty combination of HETINV_FREE() bits.
 * @param[out] out receives the map; NULL on failure.
 * @return as hetinv_param_map_create_identity(), plus INVALID_ARGUMENT for
 *         coarse_dims out of range.
 */
HETINV_API hetinv_result_t hetinv_param_map_create_coarse(const hetinv_medium_t *medium,
                                                          const int32_t coarse_dims[3],
                                                          uint32_t free_mask,
                                                          hetinv_param_map_t **out);

/**
 * @brief The grid with axis @p axis collapsed: each π cell holds the value of
 *        every voxel along that axis.
 * @param medium gives the grid; only read.
 * @param axis 0 (x), 1 (y) or 2 (z).
 * @param free_mask non-empty combination of HETINV_FREE() bits.
 * @param[out] out receives the map; NULL on failure.
 * @return as hetinv_param_map_create_identity(), plus OUT_OF_RANGE for the axis.
 */
HETINV_API hetinv_result_t hetinv_param_map_create_broadcast(const hetinv_medium_t *medium,
                                                             int32_t axis, uint32_t free_mask,
                                                             hetinv_param_map_t **out);

/** @brief Destroy a map and set @p *map to NULL; NULL is a no-op. */
HETINV_API void hetinv_param_map_destroy(hetinv_param_map_t **map);

/** @brief Length K of π; 0 for NULL. */
HETINV_API size_t hetinv_param_map_size(const hetinv_param_map_t *map);

/** @brief The map's free-parameter mask; 0 for NULL. */
HETINV_API uint32_t hetinv_param_map_free_mask(const hetinv_param_map_t *map);

/**
 * @brief Cells per axis of each free parameter's block (the medium's grid for
 *        identity, coarse_dims, or the grid with the broadcast axis set to 1).
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_param_map_get_dims(const hetinv_param_map_t *map, int32_t dims[3]);

/**
 * @brief Parameter and cell of π entry @p index. Outputs may be NULL.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_OUT_OF_RANGE.
 */
HETINV_API hetinv_result_t hetinv_param_map_entry(const hetinv_param_map_t *map, size_t index,
                                                  hetinv_param_t *param, size_t *cell);

/**
 * @brief Write π into an uncommitted medium: each free parameter's voxels
 *        receive the mapped values; the others are left as they are.
 * @param map the map.
 * @param pi hetinv_param_map_size() values. Read only.
 * @param count length of @p pi.
 * @param medium uncommitted medium with the map's grid.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT;
 *         HETINV_ERROR_INVALID_ARGUMENT (count, grid, a mapped value the
 *         medium rejects, named by its voxel); HETINV_ERROR_INVALID_STATE.
 */
HETINV_API hetinv_result_t hetinv_param_map_apply(const hetinv_param_map_t *map, const double *pi,
                                                  size_t count, hetinv_medium_t *medium);

/**
 * @brief π from a medium: identity copies, broadcast and coarse average the
 *        voxels each cell covers (an initialisation, not an exact inverse).
 * @param map the map.
 * @param medium a medium with the map's grid; only read.
 * @param[out] pi receives hetinv_param_map_size() values.
 * @param count length of @p pi.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_INVALID_ARGUMENT.
 */
HETINV_API hetinv_result_t hetinv_param_map_extract(const hetinv_param_map_t *map,
                                                    const hetinv_medium_t *medium, double *pi,
                                                    size_t count);

/**
 * @brief Chain rule: gradient with respect to π from the gradient with
 *        respect to every voxel's parameters.
 * @param map the map.
 * @param voxel_grad 3·V values: ∂/∂σa of every voxel (linear order), then
 *        ∂/∂σs, then ∂/∂g (V = the medium's voxel count).
 * @param[out] pi_grad receives hetinv_param_map_size() values.
 * @param count length of @p pi_grad.
 * @return HETINV_SUCCESS; HETINV_ERROR_NULL_ARGUMENT; HETINV_ERROR_INVALID_ARGUMENT (count).
 */
HETINV_API hetinv_result_t hetinv_param_map_pullback(const hetinv_param_map_t *map,
                                                     const double *voxel_grad, double *pi_grad,
                                                     size_t count);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_PARAM_H */
