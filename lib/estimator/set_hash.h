/* The geometry of a measurement set, hashed (set_hash.c). */
#ifndef HV_SET_HASH_H
#define HV_SET_HASH_H

#include <stdint.h>

#include "hetinv/measurement.h"

/* FNV-1a 64 of the set's box, interface and rows (emitters, sensors,
 * pathlength bins and instrument responses): equal for sets built alike,
 * in this process or another. Not the values, weights or mask. */
uint64_t hv_set_geometry_hash(const hetinv_measurements_t *set);

#endif
