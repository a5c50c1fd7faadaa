/* Counter-based random streams: Philox4x32-10 (Random123), one stream per
 * (seed, emitter, photon, stream id), so any photon's randomness can be
 * recomputed alone and results do not depend on thread scheduling.
 *
 * Philox maps a 128-bit counter and a 64-bit key to 128 random bits. The
 * stream's identity is packed injectively into the key and the counter:
 *
 *   key = seed (64 bits)
 *   ctr = { block,                       32 bits: advanced by the stream
 *           photon bits 0..31,
 *           photon bits 32..47 | stream << 16,
 *           emitter }
 *
 * hence the limits photon < 2^48 and stream < 2^16, and 2^32 Philox blocks
 * (2^33 doubles) per stream: far beyond any one photon's path.
 *
 * Key domains. Photon streams put their emitter's index in the last counter
 * word; emitters are numbered from 0 within a measurement set of at most
 * INT32_MAX rows, so that word is < 2^31. Everything else that draws random
 * numbers (simulated acquisition) uses hv_rng_init_domain with a domain
 * constant >= 2^31 in that word: its streams never coincide with a photon
 * stream, whatever the seeds, nor with another domain's. */
#ifndef HV_RNG_H
#define HV_RNG_H

#include <assert.h>
#include <stdbool.h>
#include <stdint.h>

/* Random123 trips -Wundef/-Wstrict-prototypes when not found as a system header. */
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wundef"
#pragma GCC diagnostic ignored "-Wstrict-prototypes"
#endif
#include <Random123/philox.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

#include "core/compiler.h"

#define HV_RNG_PHOTON_LIMIT (UINT64_C(1) << 48) /* photon indices are < this */
#define HV_RNG_STREAM_LIMIT (UINT32_C(1) << 16) /* stream ids are < this */

/* Blocks computed at a time. The photon loop draws one block per flight
 * (tracer.c), and Philox computed a block at a time was 28 % of A1's
 * instructions: vector multiplies take four blocks' words at once (AVX2;
 * two with SSE2), so a stream computes its next HV_RNG_QUEUE blocks
 * together and hands them out in counter order. Its outputs are those of
 * computing each block alone; a photon leaves at most HV_RNG_QUEUE - 1
 * computed blocks unused. */
#define HV_RNG_QUEUE 8

/* A stream: small, copyable, no allocation. Fields are private. */
typedef struct hv_rng {
  philox4x32_ctr_t ctr; /* ctr.v[0] is the next block to compute */
  philox4x32_key_t key;
  philox4x32_ctr_t out; /* the current block's four outputs */
  unsigned used;        /* outputs of `out` already returned (4: none left) */
  unsigned next;        /* blocks of `queue` handed out (HV_RNG_QUEUE: none left) */
  philox4x32_ctr_t queue[HV_RNG_QUEUE]; /* blocks ctr.v[0] - HV_RNG_QUEUE ... ctr.v[0] - 1 */
} hv_rng_t;

/* The stream keyed by (seed, emitter, photon, stream); see the limits above. */
static inline hv_rng_t hv_rng_init(uint64_t seed, uint32_t emitter, uint64_t photon,
                                   uint32_t stream) {
  assert(photon < HV_RNG_PHOTON_LIMIT && stream < HV_RNG_STREAM_LIMIT);
  hv_rng_t r;
  r.key.v[0] = (uint32_t)seed;
  r.key.v[1] = (uint32_t)(seed >> 32);
  r.ctr.v[0] = 0;
  r.ctr.v[1] = (uint32_t)photon;
  r.ctr.v[2] = (uint32_t)((photon >> 32) & 0xffffu) | (stream << 16);
  r.ctr.v[3] = emitter;
  r.out = r.ctr; /* never read before the first refill */
  r.used = 4;
  r.next = HV_RNG_QUEUE; /* the queue is computed at the first draw */
  return r;
}

#define HV_RNG_EMITTER_LIMIT (UINT32_C(1) << 31) /* photon streams' emitter keys are < this */
#define HV_RNG_DOMAIN_NOISE (UINT32_C(0x80000001))   /* acquire/noise.c: index = value */
#define HV_RNG_DOMAIN_MIXTURE (UINT32_C(0x80000002)) /* acquire/volume_mixture.c: index = component */
#define HV_RNG_DOMAIN_SMOKE (UINT32_C(0x80000003))   /* acquire/volume_smoke.c, smooth_noise.c */

/* A stream of a non-photon domain: keyed by (seed, domain, index, stream),
 * with the limits of hv_rng_init on index and stream. */
static inline hv_rng_t hv_rng_init_domain(uint64_t seed, uint32_t domain, uint64_t index,
                                          uint32_t stream) {
  assert(domain >= HV_RNG_EMITTER_LIMIT);
  return hv_rng_init(seed, domain, index, stream);
}

/* The raw generator: Philox4x32-10 of one counter under one key. */
static inline philox4x32_ctr_t hv_philox4x32_10(philox4x32_ctr_t ctr, philox4x32_key_t key) {
  return philox4x32_R(10, ctr, key);
}

/* Philox4x32-10 of the HV_RNG_QUEUE counters r->ctr, r->ctr + 1, ... (the
 * first word incremented modulo 2^32, as the stream advances it) into
 * r->queue, and r->ctr moved past them (core/rng.c: wide lanes where the
 * processor has them, the outputs of hv_philox4x32_10 in every case). */
void hv_rng_fill_queue(hv_rng_t *r);

/* For tests: hv_rng_fill_queue by a named implementation; false (and r
 * unchanged) where this build or processor lacks it. */
typedef enum hv_rng_fill { HV_RNG_FILL_PORTABLE, HV_RNG_FILL_SSE2, HV_RNG_FILL_AVX2 } hv_rng_fill_t;
bool hv_rng_fill_queue_using(hv_rng_t *r, hv_rng_fill_t fill);

/* The stream's next block, in counter order. */
HV_ALWAYS_INLINE static inline philox4x32_ctr_t hv_rng_next_block(hv_rng_t *r) {
  if (r->next == HV_RNG_QUEUE) {
    hv_rng_fill_queue(r);
    r->next = 0;
  }
  return r->queue[r->next++];
}

/* Next 32 random bits. */
HV_ALWAYS_INLINE static inline uint32_t hv_rng_u32(hv_rng_t *r) {
  if (r->used == 4) {
    r->out = hv_rng_next_block(r);
    r->used = 0;
  }
  return r->out.v[r->used++];
}

/* A whole fresh block (four 32-bit outputs) — the buffered outputs of
 * hv_rng_u32 come from other counters, so nothing is used twice. */
static inline philox4x32_ctr_t hv_rng_block(hv_rng_t *r) { return hv_rng_next_block(r); }

/* Next 64 random bits (two outputs, the first in the high half). */
HV_ALWAYS_INLINE static inline uint64_t hv_rng_u64(hv_rng_t *r) {
  uint64_t hi = hv_rng_u32(r);
  return hi << 32 | hv_rng_u32(r);
}

/* Uniform in [0, 1) from 64 random bits: the top 53 as a multiple of 2^-53. */
static inline double hv_unit_from_bits(uint64_t bits) {
  return (double)(bits >> 11) * 0x1p-53;
}

/* Uniform in (0, 1) from 64 random bits: (k + 1/2)·2^-52 for the top 52 bits
 * k, so 0 and 1 never occur and -log(u) is finite and > 0 (at most 53 ln 2 ≈
 * 36.7). 52 bits, not 53, because (2^53 - 1/2)·2^-53 would round to 1. */
static inline double hv_open_unit_from_bits(uint64_t bits) {
  return ((double)(bits >> 12) + 0.5) * 0x1p-52;
}

/* Uniform in [0, 1) from 32 random bits (enough for angles). */
static inline double hv_unit_from_u32(uint32_t bits) { return (double)bits * 0x1p-32; }

/* Uniform in [0, 1) with 53 random bits. */
HV_ALWAYS_INLINE static inline double hv_rng_uniform(hv_rng_t *r) { return hv_unit_from_bits(hv_rng_u64(r)); }

/* Uniform in (0, 1), for -log(u) and the like. */
static inline double hv_rng_uniform_open(hv_rng_t *r) {
  return hv_open_unit_from_bits(hv_rng_u64(r));
}

#endif
