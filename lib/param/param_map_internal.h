/* What the estimator needs to know of a parameter map. */
#ifndef HV_PARAM_MAP_INTERNAL_H
#define HV_PARAM_MAP_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>

#include "hetinv/param.h"

/* The context the map was created in (for errors and allocation). */
const hetinv_context_t *hv_param_map_context(const hetinv_param_map_t *map);

/* True if the map was made for the medium's grid. */
bool hv_param_map_fits(const hetinv_param_map_t *map, const hetinv_medium_t *medium);

/* Tangents pushed forward to voxels (the transpose of
 * hetinv_param_map_pullback): pi holds `tangents` vectors of
 * hetinv_param_map_size() entries, tangent t at pi[t·K + i]; voxel
 * receives 3·V·tangents values, entry (parameter p, voxel k) of tangent t
 * at voxel[(p·V + k)·tangents + t], zero for parameters the map keeps
 * fixed. */
void hv_param_map_pushforward(const hetinv_param_map_t *map, const double *pi, int32_t tangents,
                              double *voxel);

#endif
