/* Counter-based random streams (lib/core/rng.h). */
#include <math.h>
#include <stdlib.h>

#include "test_support.h"

#include "core/rng.h"

/* Statistical tests draw from this seed; HETINV_TEST_SEED overrides it. */
static uint64_t test_seed(void) {
  const char *s = getenv("HETINV_TEST_SEED");
  return s != NULL ? strtoull(s, NULL, 0) : UINT64_C(0x243f6a8885a308d3);
}

static void philox_matches_random123_known_answers(void **state) {
  (void)state;
  /* Random123 tests/kat_vectors, the three "philox4x32 10" lines:
   * counter (4 words), key (2 words), expected output (4 words). */
  static const uint32_t kat[3][10] = {
      {0, 0, 0, 0, 0, 0, 0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8},
      {0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff, 0x408f276d,
       0x41c83b0e, 0xa20bc7c6, 0x6d5451fd},
      {0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344, 0xa4093822, 0x299f31d0, 0xd16cfe09,
       0x94fdcceb, 0x5001e420, 0x24126ea1},
  };
  for (int i = 0; i < 3; ++i) {
    philox4x32_ctr_t c = {{kat[i][0], kat[i][1], kat[i][2], kat[i][3]}};
    philox4x32_key_t k = {{kat[i][4], kat[i][5]}};
    philox4x32_ctr_t out = hv_philox4x32_10(c, k);
    for (int j = 0; j < 4; ++j) assert_int_equal(out.v[j], kat[i][6 + j]);
  }
}

static void stream_is_philox_of_the_packed_key_and_counter(void **state) {
  (void)state;
  uint64_t seed = UINT64_C(0x0123456789abcdef), photon = UINT64_C(0xba9876543210);
  hv_rng_t r = hv_rng_init(seed, 0xdeadbeefu, photon, 0x1234u);
  philox4x32_key_t k = {{0x89abcdefu, 0x01234567u}};
  for (uint32_t block = 0; block < 3; ++block) {
    philox4x32_ctr_t c = {{block, 0x76543210u, 0x1234ba98u, 0xdeadbeefu}};
    philox4x32_ctr_t out = hv_philox4x32_10(c, k);
    for (int j = 0; j < 4; ++j) assert_int_equal(hv_rng_u32(&r), out.v[j]);
  }
}

/* Each fill of the block queue (core/rng.c) gives Philox of each counter
 * alone, also where the first counter word wraps around 2^32. */
static void every_queue_fill_is_philox_block_by_block(void **state) {
  (void)state;
  const hv_rng_fill_t fills[] = {HV_RNG_FILL_PORTABLE, HV_RNG_FILL_SSE2, HV_RNG_FILL_AVX2};
  const uint32_t starts[] = {0, 0xfffffffbu};
  int ran = 0;
  for (size_t f = 0; f < sizeof fills / sizeof fills[0]; ++f) {
    for (size_t s = 0; s < 2; ++s) {
      hv_rng_t r = hv_rng_init(UINT64_C(0xfedcba9876543210), 0x7u, UINT64_C(0xabcdef012345), 0x99u);
      r.ctr.v[0] = starts[s];
      philox4x32_ctr_t c = r.ctr;
      if (!hv_rng_fill_queue_using(&r, fills[f])) continue;
      ++ran;
      for (int fill = 0; fill < 3; ++fill) {
        if (fill > 0) assert_true(hv_rng_fill_queue_using(&r, fills[f]));
        for (unsigned b = 0; b < HV_RNG_QUEUE; ++b, ++c.v[0]) {
          philox4x32_ctr_t want = hv_philox4x32_10(c, r.key);
          for (int j = 0; j < 4; ++j) assert_int_equal(r.queue[b].v[j], want.v[j]);
        }
        assert_int_equal(r.ctr.v[0], c.v[0]);
      }
    }
  }
  assert_true(ran >= 2); /* the portable fill at least */
}

/* Whole blocks and single outputs come from one counter sequence, in
 * order, across the queue's refills. */
static void blocks_and_outputs_share_the_counter_order(void **state) {
  (void)state;
  hv_rng_t r = hv_rng_init(11, 5, 77, 3);
  philox4x32_ctr_t c = r.ctr;
  philox4x32_key_t k = r.key;
  philox4x32_ctr_t cur = c;
  int left = 0;
  for (int i = 0; i < 5 * HV_RNG_QUEUE; ++i) {
    if (i % 3 == 1) {
      philox4x32_ctr_t got = hv_rng_block(&r), want = hv_philox4x32_10(c, k);
      ++c.v[0];
      for (int j = 0; j < 4; ++j) assert_int_equal(got.v[j], want.v[j]);
    } else {
      if (left == 0) {
        cur = hv_philox4x32_10(c, k);
        ++c.v[0];
        left = 4;
      }
      assert_int_equal(hv_rng_u32(&r), cur.v[4 - left]);
      --left;
    }
  }
}

static void same_key_gives_same_sequence(void **state) {
  (void)state;
  hv_rng_t a = hv_rng_init(7, 3, 1000, 2), b = hv_rng_init(7, 3, 1000, 2);
  for (int i = 0; i < 1000; ++i) {
    /* Mixed widths: the buffer hands out each 32-bit output exactly once. */
    if (i % 3 == 0) assert_int_equal(hv_rng_u32(&a), hv_rng_u32(&b));
    else assert_true(hv_rng_uniform(&a) == hv_rng_uniform(&b));
  }
}

static void every_key_component_changes_the_sequence(void **state) {
  (void)state;
  const uint64_t limit = HV_RNG_PHOTON_LIMIT;
  hv_rng_t keys[] = {
      hv_rng_init(1, 2, 3, 4),         hv_rng_init(2, 2, 3, 4),
      hv_rng_init(1ull << 40, 2, 3, 4), hv_rng_init(1, 3, 3, 4),
      hv_rng_init(1, 2, 4, 4),         hv_rng_init(1, 2, 3 + (1ull << 40), 4),
      hv_rng_init(1, 2, limit - 1, 4), hv_rng_init(1, 2, 3, 5),
      hv_rng_init(1, 2, 3, HV_RNG_STREAM_LIMIT - 1),
  };
  enum { n = sizeof keys / sizeof keys[0] };
  uint64_t first[n];
  for (int i = 0; i < n; ++i) first[i] = hv_rng_u64(&keys[i]);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) assert_true(first[i] != first[j]);
  }
}

static void uniforms_stay_in_their_intervals(void **state) {
  (void)state;
  hv_rng_t r = hv_rng_init(test_seed(), 0, 0, 0);
  double lo = 1.0, hi = 0.0, lo_open = 1.0, hi_open = 0.0;
  for (int i = 0; i < 1000000; ++i) {
    double u = hv_rng_uniform(&r), v = hv_rng_uniform_open(&r);
    lo = fmin(lo, u), hi = fmax(hi, u);
    lo_open = fmin(lo_open, v), hi_open = fmax(hi_open, v);
  }
  assert_true(lo >= 0.0 && hi < 1.0);
  assert_true(lo_open > 0.0 && hi_open < 1.0);
  assert_true(lo < 1e-5 && hi > 1.0 - 1e-5); /* and they fill the interval */
  /* The conversions' extremes: all bits 0, all bits 1. */
  assert_true(hv_unit_from_bits(0) == 0.0);
  assert_true(hv_unit_from_bits(UINT64_MAX) == 1.0 - 0x1p-53);
  assert_true(hv_open_unit_from_bits(0) == 0x1p-53);
  assert_true(hv_open_unit_from_bits(UINT64_MAX) == 1.0 - 0x1p-53);
  assert_true(-log(hv_open_unit_from_bits(UINT64_MAX)) > 0.0);
}

static void uniform_mean_and_variance_match(void **state) {
  (void)state;
  const uint64_t seed = test_seed();
  const int n = 1000000;
  hv_rng_t r = hv_rng_init(seed, 1, 0, 0);
  double sum = 0.0, sum_sq = 0.0;
  for (int i = 0; i < n; ++i) {
    double d = hv_rng_uniform(&r) - 0.5;
    sum += d;
    sum_sq += d * d;
  }
  /* U - 1/2 has mean 0 and variance 1/12; (U - 1/2)² has variance 1/180. */
  double mean_z = (sum / n) / sqrt(1.0 / 12.0 / n);
  double var_z = (sum_sq / n - 1.0 / 12.0) / sqrt(1.0 / 180.0 / n);
  if (fabs(mean_z) > 4.0 || fabs(var_z) > 4.0) {
    print_error("seed %#llx: mean off by %.2f and variance by %.2f standard errors\n",
                (unsigned long long)seed, mean_z, var_z);
    fail();
  }
}

static void neighbouring_photons_are_uncorrelated(void **state) {
  (void)state;
  /* Photon streams differ only in the counter: their first draws must not
   * be correlated (sample correlation ~ N(0, 1/n)). */
  const uint64_t seed = test_seed();
  const int n = 200000;
  double prev = 0.0, sum = 0.0;
  for (int i = 0; i <= n; ++i) {
    hv_rng_t r = hv_rng_init(seed, 0, (uint64_t)i, 0);
    double u = hv_rng_uniform(&r) - 0.5;
    sum += prev * u; /* i = 0 adds nothing */
    prev = u;
  }
  double z = (sum / n) / (1.0 / 12.0) * sqrt((double)n);
  if (fabs(z) > 4.0) {
    print_error("seed %#llx: lag-1 correlation across photons is %.2f standard errors\n",
                (unsigned long long)seed, z);
    fail();
  }
}

static void domain_streams_sit_above_every_emitter_key(void **state) {
  (void)state;
  /* A domain occupies the emitter word with a value no emitter index
   * (< 2^31) can take, so it never reproduces a photon stream. */
  const uint32_t domains[] = {HV_RNG_DOMAIN_NOISE, HV_RNG_DOMAIN_MIXTURE, HV_RNG_DOMAIN_SMOKE};
  for (int d = 0; d < 3; ++d) {
    assert_true(domains[d] >= HV_RNG_EMITTER_LIMIT);
    for (int e = 0; e < d; ++e) assert_true(domains[d] != domains[e]);
    hv_rng_t a = hv_rng_init_domain(9, domains[d], 5, 1), b = hv_rng_init(9, domains[d], 5, 1);
    for (int i = 0; i < 8; ++i) assert_int_equal(hv_rng_u32(&a), hv_rng_u32(&b));
    hv_rng_t photon = hv_rng_init(9, domains[d] & ~HV_RNG_EMITTER_LIMIT, 5, 1);
    a = hv_rng_init_domain(9, domains[d], 5, 1);
    assert_true(hv_rng_u64(&a) != hv_rng_u64(&photon));
  }
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(philox_matches_random123_known_answers),
      cmocka_unit_test(stream_is_philox_of_the_packed_key_and_counter),
      cmocka_unit_test(every_queue_fill_is_philox_block_by_block),
      cmocka_unit_test(blocks_and_outputs_share_the_counter_order),
      cmocka_unit_test(same_key_gives_same_sequence),
      cmocka_unit_test(every_key_component_changes_the_sequence),
      cmocka_unit_test(uniforms_stay_in_their_intervals),
      cmocka_unit_test(uniform_mean_and_variance_match),
      cmocka_unit_test(neighbouring_photons_are_uncorrelated),
      cmocka_unit_test(domain_streams_sit_above_every_emitter_key),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
