/* The stream's block queue (core/rng.h): Philox4x32-10 of HV_RNG_QUEUE
 * consecutive counters at once. Each 64-bit lane of a register holds one
 * block's word in its low half; _mm*_mul_epu32 multiplies those low halves
 * into full 64-bit products, which is exactly Philox's mulhilo, so one
 * instruction does four blocks' (AVX2) or two blocks' (SSE2) multiply. The
 * high halves are never read by the multiply, so they may hold anything
 * until the words are packed. A round of one block, as in Random123:
 *   (hi0, lo0) = M0·c0, (hi1, lo1) = M1·c2,
 *   c' = {hi1 ^ c1 ^ k0, lo1, hi0 ^ c3 ^ k1, lo0},
 * with the key bumped by (W0, W1) between rounds. tests/unit/core_rng.c
 * checks the queue against hv_philox4x32_10 block by block. */
#include "core/rng.h"

_Static_assert(HV_RNG_QUEUE % 8 == 0, "the vector fills take blocks eight at a time");

static void fill_portable(hv_rng_t *r) {
  philox4x32_ctr_t c = r->ctr;
  for (unsigned b = 0; b < HV_RNG_QUEUE; ++b) {
    r->queue[b] = hv_philox4x32_10(c, r->key);
    ++c.v[0];
  }
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

#define HV_PHILOX_ROUND(mul, srli, xor, w0, w1, w2, w3, k0, k1, m0, m1)                     \
  do {                                                                                      \
    __typeof__(w0) p0_ = mul(w0, m0), p1_ = mul(w2, m1);                                    \
    w0 = xor(xor(srli(p1_, 32), w1), k0);                                                   \
    w1 = p1_;                                                                               \
    w2 = xor(xor(srli(p0_, 32), w3), k1);                                                   \
    w3 = p0_;                                                                               \
  } while (0)

__attribute__((target("avx2"))) static void fill_avx2(hv_rng_t *r) {
  const __m256i m0 = _mm256_set1_epi64x(PHILOX_M4x32_0), m1 = _mm256_set1_epi64x(PHILOX_M4x32_1);
  const __m256i bump0 = _mm256_set1_epi64x(PHILOX_W32_0), bump1 = _mm256_set1_epi64x(PHILOX_W32_1);
  const uint32_t c = r->ctr.v[0];
  for (unsigned b = 0; b < HV_RNG_QUEUE; b += 8) {
    /* Two independent sets of four blocks, so one set's multiply latency
     * hides behind the other's. */
    __m256i a0 = _mm256_set_epi64x((uint32_t)(c + b + 3), (uint32_t)(c + b + 2),
                                   (uint32_t)(c + b + 1), (uint32_t)(c + b));
    __m256i e0 = _mm256_add_epi32(a0, _mm256_set1_epi64x(4));
    __m256i a1 = _mm256_set1_epi64x(r->ctr.v[1]), a2 = _mm256_set1_epi64x(r->ctr.v[2]),
            a3 = _mm256_set1_epi64x(r->ctr.v[3]);
    __m256i e1 = a1, e2 = a2, e3 = a3;
    __m256i k0 = _mm256_set1_epi64x(r->key.v[0]), k1 = _mm256_set1_epi64x(r->key.v[1]);
    for (int round = 0; round < 10; ++round) {
      HV_PHILOX_ROUND(_mm256_mul_epu32, _mm256_srli_epi64, _mm256_xor_si256, a0, a1, a2, a3, k0, k1,
                      m0, m1);
      HV_PHILOX_ROUND(_mm256_mul_epu32, _mm256_srli_epi64, _mm256_xor_si256, e0, e1, e2, e3, k0, k1,
                      m0, m1);
      k0 = _mm256_add_epi32(k0, bump0); /* the high halves stay 0 */
      k1 = _mm256_add_epi32(k1, bump1);
    }
    /* Per 128-bit half, dwords {w(x), -, w(x+1), -} to blocks {w0, w1, w2, w3}:
     * half 0 holds blocks x, x+1 = b, b+1 and half 1 holds b+2, b+3. */
    __m256i sets[2][4] = {{a0, a1, a2, a3}, {e0, e1, e2, e3}};
    for (int s = 0; s < 2; ++s) {
      __m256i *w = sets[s];
      __m256i lo01 = _mm256_unpacklo_epi32(w[0], w[1]), hi01 = _mm256_unpackhi_epi32(w[0], w[1]);
      __m256i lo23 = _mm256_unpacklo_epi32(w[2], w[3]), hi23 = _mm256_unpackhi_epi32(w[2], w[3]);
      __m256i even = _mm256_unpacklo_epi64(lo01, lo23); /* blocks b, b+2 */
      __m256i odd = _mm256_unpacklo_epi64(hi01, hi23);  /* blocks b+1, b+3 */
      philox4x32_ctr_t *q = &r->queue[b + 4 * (unsigned)s];
      _mm256_storeu_si256((__m256i *)(void *)q[0].v, _mm256_permute2x128_si256(even, odd, 0x20));
      _mm256_storeu_si256((__m256i *)(void *)q[2].v, _mm256_permute2x128_si256(even, odd, 0x31));
    }
  }
}

static void fill_sse2(hv_rng_t *r) {
  const __m128i m0 = _mm_set1_epi64x(PHILOX_M4x32_0), m1 = _mm_set1_epi64x(PHILOX_M4x32_1);
  const __m128i bump0 = _mm_set1_epi64x(PHILOX_W32_0), bump1 = _mm_set1_epi64x(PHILOX_W32_1);
  const uint32_t c = r->ctr.v[0];
  for (unsigned b = 0; b < HV_RNG_QUEUE; b += 4) {
    __m128i a0 = _mm_set_epi64x((uint32_t)(c + b + 1), (uint32_t)(c + b));
    __m128i e0 = _mm_add_epi32(a0, _mm_set1_epi64x(2));
    __m128i a1 = _mm_set1_epi64x(r->ctr.v[1]), a2 = _mm_set1_epi64x(r->ctr.v[2]),
            a3 = _mm_set1_epi64x(r->ctr.v[3]);
    __m128i e1 = a1, e2 = a2, e3 = a3;
    __m128i k0 = _mm_set1_epi64x(r->key.v[0]), k1 = _mm_set1_epi64x(r->key.v[1]);
    for (int round = 0; round < 10; ++round) {
      HV_PHILOX_ROUND(_mm_mul_epu32, _mm_srli_epi64, _mm_xor_si128, a0, a1, a2, a3, k0, k1, m0, m1);
      HV_PHILOX_ROUND(_mm_mul_epu32, _mm_srli_epi64, _mm_xor_si128, e0, e1, e2, e3, k0, k1, m0, m1);
      k0 = _mm_add_epi32(k0, bump0);
      k1 = _mm_add_epi32(k1, bump1);
    }
    __m128i sets[2][4] = {{a0, a1, a2, a3}, {e0, e1, e2, e3}};
    for (int s = 0; s < 2; ++s) {
      __m128i *w = sets[s];
      __m128i lo01 = _mm_unpacklo_epi32(w[0], w[1]), hi01 = _mm_unpackhi_epi32(w[0], w[1]);
      __m128i lo23 = _mm_unpacklo_epi32(w[2], w[3]), hi23 = _mm_unpackhi_epi32(w[2], w[3]);
      philox4x32_ctr_t *q = &r->queue[b + 2 * (unsigned)s];
      _mm_storeu_si128((__m128i *)(void *)q[0].v, _mm_unpacklo_epi64(lo01, lo23));
      _mm_storeu_si128((__m128i *)(void *)q[1].v, _mm_unpacklo_epi64(hi01, hi23));
    }
  }
}

static bool has_avx2(void) { return __builtin_cpu_supports("avx2"); }
#define HV_RNG_HAS_SSE2 1
#else
static bool has_avx2(void) { return false; }
#define HV_RNG_HAS_SSE2 0
static void fill_avx2(hv_rng_t *r) { fill_portable(r); }
static void fill_sse2(hv_rng_t *r) { fill_portable(r); }
#endif

void hv_rng_fill_queue(hv_rng_t *r) {
  if (has_avx2()) fill_avx2(r);
  else if (HV_RNG_HAS_SSE2) fill_sse2(r);
  else fill_portable(r);
  r->ctr.v[0] += HV_RNG_QUEUE;
}

bool hv_rng_fill_queue_using(hv_rng_t *r, hv_rng_fill_t fill) {
  switch (fill) {
  case HV_RNG_FILL_PORTABLE: fill_portable(r); break;
  case HV_RNG_FILL_SSE2:
    if (!HV_RNG_HAS_SSE2) return false;
    fill_sse2(r);
    break;
  case HV_RNG_FILL_AVX2:
    if (!has_avx2()) return false;
    fill_avx2(r);
    break;
  default: return false;
  }
  r->ctr.v[0] += HV_RNG_QUEUE;
  return true;
}
