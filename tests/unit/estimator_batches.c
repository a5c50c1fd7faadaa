/* White-box tests of the batch loop (estimator/batches.c): items are reduced
 * exactly once, in item order, from the slot they ran in, and no slot holds
 * two items at once, for any thread and slot count; items of uneven length
 * (some sleep) make threads run ahead and wait for a slot. And the slot
 * count a pass asks for (pass.c). About a second in all. */
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
#include <time.h>

#include "test_support.h"
#include "estimator/batches.h"
#include "estimator/pass.h"

#define VALUES 8
#define MAX_TEST_SLOTS 16

typedef struct loop_check {
  double tally[MAX_TEST_SLOTS][VALUES];
  atomic_int in_use[MAX_TEST_SLOTS]; /* 1 from an item's run to its reduce */
  atomic_int clashes;                /* runs that found their slot in use */
  int64_t next;                      /* the item the next reduce must get */
  int wrong_order, wrong_tally;
  double total;
} loop_check_t;

static void check_run(void *self, int64_t item, int slot) {
  loop_check_t *c = self;
  if (atomic_exchange(&c->in_use[slot], 1) != 0) atomic_fetch_add(&c->clashes, 1);
  if (item % 5 == 0) { /* uneven items: others run ahead into the spare slots */
    struct timespec ts = {0, 100000 * (long)(item % 3)};
    nanosleep(&ts, NULL);
  }
  for (int j = 0; j < VALUES; ++j) c->tally[slot][j] = 0.25 * (double)item + j;
}

static void check_reduce(void *self, int64_t item, int slot) {
  loop_check_t *c = self;
  if (item != c->next) c->wrong_order++;
  c->next = item + 1;
  for (int j = 0; j < VALUES; ++j) {
    if (c->tally[slot][j] != 0.25 * (double)item + j) c->wrong_tally++;
    c->total += c->tally[slot][j];
  }
  atomic_store(&c->in_use[slot], 0);
}

static void test_order_and_slots(void **state) {
  (void)state;
  static const int64_t item_counts[] = {0, 1, 3, 101};
  static const int slot_counts[] = {0, 1, 2, 3, 8, 16};
  for (int threads = 1; threads <= 4; ++threads) {
    for (size_t s = 0; s < sizeof slot_counts / sizeof *slot_counts; ++s) {
      for (size_t n = 0; n < sizeof item_counts / sizeof *item_counts; ++n) {
        static loop_check_t c;
        c = (loop_check_t){0};
        for (int k = 0; k < MAX_TEST_SLOTS; ++k) atomic_init(&c.in_use[k], 0);
        atomic_init(&c.clashes, 0);
        hv_batch_loop_t loop = {item_counts[n], threads, &c, check_run, check_reduce,
                                slot_counts[s]};
        hv_batches_run(&loop);
        int64_t items = item_counts[n];
        double expect = 0.0;
        for (int64_t i = 0; i < items; ++i) {
          for (int j = 0; j < VALUES; ++j) expect += 0.25 * (double)i + j;
        }
        if (c.next != items || c.wrong_order || c.wrong_tally || atomic_load(&c.clashes)) {
          print_message("threads %d, slots %d, items %lld: reduced %lld, %d out of order, %d "
                        "wrong tallies, %d slot clashes\n",
                        threads, slot_counts[s], (long long)items, (long long)c.next,
                        c.wrong_order, c.wrong_tally, atomic_load(&c.clashes));
        }
        assert_int_equal(c.next, items);
        assert_int_equal(c.wrong_order, 0);
        assert_int_equal(c.wrong_tally, 0);
        assert_int_equal(atomic_load(&c.clashes), 0);
        assert_true(c.total == expect); /* the same order of additions */
      }
    }
  }
}

/* HV_BATCH_SLOTS_PER_THREAD per thread for small tallies on several threads,
 * else one; capped by the items and the 4 GiB tally budget; never more
 * threads than slots. */
static void test_slot_count(void **state) {
  (void)state;
  hv_pass_t pass = {.threads = 2, .emitter_lo = 0, .emitter_hi = 1, .batches = 64};
  int threads = 0;
  assert_int_equal(hv_pass_slot_count(&pass, 1000, &threads), 2 * HV_BATCH_SLOTS_PER_THREAD);
  assert_int_equal(threads, 2);
  /* A gradient-sized tally: one slot per thread. */
  assert_int_equal(hv_pass_slot_count(&pass, HV_BATCH_SPARE_SLOT_BYTES + 1, &threads), 2);
  assert_int_equal(threads, 2);
  pass.batches = 3; /* 3 items */
  assert_int_equal(hv_pass_slot_count(&pass, 1000, &threads), 3);
  assert_int_equal(threads, 2);
  pass.batches = 64;
  assert_int_equal(hv_pass_slot_count(&pass, (size_t)2 << 30, &threads), 2);
  assert_int_equal(threads, 2);
  assert_int_equal(hv_pass_slot_count(&pass, (size_t)3 << 30, &threads), 1);
  assert_int_equal(threads, 1);
  pass.threads = 1; /* one thread never waits: no spare slot */
  assert_int_equal(hv_pass_slot_count(&pass, 8, &threads), 1);
  assert_int_equal(threads, 1);
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(test_order_and_slots),
      cmocka_unit_test(test_slot_count),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
