/* Photons of a uniform or delta-tracked grid, four at a time in SIMD
 * lanes, in forward and gradient passes.
 *
 * The scalar loop (tracer.c) is one photon's chain of dependent steps: a
 * free flight, then the phase function's division, square root and
 * rotation, each waiting on the last. Four photons side by side in vector
 * registers run four such chains for about the price of one. A lane
 * follows its photon exactly as hv_trace_photon would, on the photon's own
 * stream, with the same arithmetic in the same order; exits, Fresnel and
 * Russian roulette leave the vectors for scalar code (photon.h), and what
 * each photon adds to the tally is kept aside and added in photon order
 * (in a gradient pass with its score log, applied then). So a tally holds
 * bitwise what tracing the photons one after another gives: the lanes
 * change speed, not results. */
#ifndef HV_LANES_H
#define HV_LANES_H

#include <stdbool.h>
#include <stdint.h>

#include "transport/tracer.h"

/* Whether hv_trace_lanes can trace plan's photons into tally: a forward
 * or gradient tally (not the tangent mode of J·v), a grid that is uniform
 * or delta-tracked (not stepped: the lanes do not walk voxel faces), and a
 * plan without vertex sensors (its sensors score exits only). */
bool hv_lanes_fit(const hv_tracer_t *tr, const hv_plan_t *plan, const hv_tally_t *tally);

/* Photons first ... end - 1 of plan's emitter, photon p on the stream
 * hv_rng_init(seed, plan->key, p, stream): the tally receives bitwise what
 * hv_trace_photon gives them one after another. hv_lanes_fit must hold. */
void hv_trace_lanes(const hv_tracer_t *tr, const hv_plan_t *plan, uint64_t seed, uint32_t stream,
                    uint64_t first, uint64_t end, hv_tally_t *tally);

#endif
