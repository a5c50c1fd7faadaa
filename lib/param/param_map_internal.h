/* What the estimator needs to know of a parameter map. */
#ifndef HV_PARAM_MAP_INTERNAL_H
#define HV_PARAM_MAP_INTERNAL_H

#include <stdbool.h>

#include "hetinv/param.h"

/* True if the map was made for the medium's grid. */
bool hv_param_map_fits(const hetinv_param_map_t *map, const hetinv_medium_t *medium);

#endif
