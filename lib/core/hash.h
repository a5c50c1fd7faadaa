/* FNV-1a 64: the library's fingerprint of bytes (checkpoints' checksums and
 * the configuration hashes they compare). Not a cryptographic hash: it
 * tells a damaged file or another configuration, not a forged one. */
#ifndef HV_HASH_H
#define HV_HASH_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define HV_FNV_OFFSET UINT64_C(0xcbf29ce484222325)

/* FNV-1a 64 of n bytes, continuing from h (start at HV_FNV_OFFSET). */
static inline uint64_t hv_fnv1a(uint64_t h, const void *data, size_t n) {
  const unsigned char *p = data;
  for (size_t i = 0; i < n; ++i) {
    h ^= p[i];
    h *= UINT64_C(0x100000001b3);
  }
  return h;
}

/* The same over n doubles taken as 64-bit words: eight times fewer steps,
 * for large arrays (a medium's grids). */
static inline uint64_t hv_fnv1a_doubles(uint64_t h, const double *data, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    uint64_t w;
    memcpy(&w, &data[i], sizeof w);
    h ^= w;
    h *= UINT64_C(0x100000001b3);
  }
  return h;
}

#endif
