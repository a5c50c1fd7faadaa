/* A measurement set hashed (set_hash.c): what checkpoints and the ranks of
 * a collective call compare. */
#ifndef HV_SET_HASH_H
#define HV_SET_HASH_H

#include <stdint.h>

#include "hetinv/measurement.h"

/* FNV-1a 64 of the set's box, interface and rows (emitters, sensors,
 * pathlength bins and instrument responses): equal for sets built alike,
 * in this process or another. Not the values, weights or mask. */
uint64_t hv_set_geometry_hash(const hetinv_measurements_t *set);

/* FNV-1a 64 of the set's measured values, weights and mask, and of its
 * loss clip's scales where one differs from 1. Checkpoints store it: it
 * must not change. */
uint64_t hv_set_values_hash(const hetinv_measurements_t *set);

#endif
