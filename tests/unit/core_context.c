/* Context creation, allocator hooks, error reporting per thread. */
#include <pthread.h>
#include <stddef.h>
#include <stdlib.h>

#include "test_support.h"

static void default_context_has_threads_and_seed_zero(void **state) {
  (void)state;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(NULL, &ctx));
  assert_non_null(ctx);
  assert_true(hetinv_context_thread_count(ctx) >= 1);
  assert_int_equal(hetinv_context_seed(ctx), 0);
  hetinv_context_destroy(&ctx);
  assert_null(ctx);
}

static void initialiser_sets_threads_and_seed(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = 3;
  init.seed = 0x1234567890abcdefULL;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  assert_int_equal(hetinv_context_thread_count(ctx), 3);
  assert_true(hetinv_context_seed(ctx) == 0x1234567890abcdefULL);
  hetinv_context_destroy(&ctx);
}

/* Without MPI running (this test never initialises it) a context is
 * rank 0 of 1 in either build; NULL gives the same; its agreement is its
 * own status. */
static void context_without_mpi_is_rank_zero_of_one(void **state) {
  (void)state;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(NULL, &ctx));
  assert_int_equal(hetinv_context_rank(ctx), 0);
  assert_int_equal(hetinv_context_rank_count(ctx), 1);
  assert_int_equal(hetinv_context_rank(NULL), 0);
  assert_int_equal(hetinv_context_rank_count(NULL), 1);
  /* One rank agrees with itself: its own status comes back. */
  assert_int_equal(hetinv_context_agree(ctx, HETINV_SUCCESS), HETINV_SUCCESS);
  assert_int_equal(hetinv_context_agree(ctx, HETINV_ERROR_IO), HETINV_ERROR_IO);
  /* Every failure is rank 0's; none to report for another context. */
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_fill(NULL, 1, 1, 0));
  assert_int_equal(hetinv_context_last_error_rank(NULL), 0);
  assert_int_equal(hetinv_context_last_error_rank(ctx), -1);
  double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
  int32_t n[3] = {1, 1, 1};
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_create(ctx, lo, hi, n, NULL));
  assert_int_equal(hetinv_context_last_error_rank(ctx), 0);
  int has = hetinv_build_has_mpi();
  assert_true(has == 0 || has == 1);
  hetinv_context_destroy(&ctx);
}

static void destroy_accepts_null(void **state) {
  (void)state;
  hetinv_context_destroy(NULL);
  hetinv_context_t *ctx = NULL;
  hetinv_context_destroy(&ctx);
  assert_null(ctx);
  assert_int_equal(hetinv_context_thread_count(NULL), 0);
}

static void null_output_is_rejected(void **state) {
  (void)state;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_context_create(NULL, NULL));
  assert_message_contains("hetinv_context_create");
  assert_int_equal(hetinv_context_last_error_code(NULL), HETINV_ERROR_NULL_ARGUMENT);
}

static void too_small_init_size_is_rejected(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.size = sizeof(size_t);
  hetinv_context_t *ctx = (hetinv_context_t *)&init; /* must be reset to NULL */
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_context_create(&init, &ctx));
  assert_null(ctx);
  assert_message_contains("init->size");
}

static void larger_init_from_a_newer_header_is_accepted(void **state) {
  (void)state;
  /* A program compiled against a future header passes a bigger struct. */
  struct {
    hetinv_context_init_t v1;
    double future_member;
  } bigger = {HETINV_CONTEXT_INIT_DEFAULT, 1.0};
  bigger.v1.size = sizeof bigger;
  bigger.v1.seed = 7;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&bigger.v1, &ctx));
  assert_int_equal(hetinv_context_seed(ctx), 7);
  hetinv_context_destroy(&ctx);
}

static void negative_thread_count_is_rejected(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.thread_count = -2;
  hetinv_context_t *ctx = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_context_create(&init, &ctx));
  assert_message_contains("thread_count is -2");
}

static void *counting_alloc(void *user, size_t size) {
  ++((int *)user)[0];
  return malloc(size);
}
static void counting_free(void *user, void *ptr) {
  ++((int *)user)[1];
  free(ptr);
}

static void allocator_hooks_are_used_and_balanced(void **state) {
  (void)state;
  int counts[2] = {0, 0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = counting_alloc;
  init.free_fn = counting_free;
  init.alloc_user_data = counts;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  hetinv_medium_t *m = NULL;
  assert_ok(hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1},
                                 (int32_t[]){2, 2, 2}, &m));
  hetinv_medium_destroy(&m);
  hetinv_context_destroy(&ctx);
  assert_true(counts[0] >= 2);
  assert_int_equal(counts[0], counts[1]);
}

static void half_an_allocator_is_rejected(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = counting_alloc;
  hetinv_context_t *ctx = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_context_create(&init, &ctx));
  assert_message_contains("free_fn is NULL");
}

static void *failing_alloc(void *user, size_t size) {
  (void)user, (void)size;
  return NULL;
}

static void allocation_failure_is_reported(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = failing_alloc;
  init.free_fn = counting_free;
  hetinv_context_t *ctx = NULL;
  assert_result(HETINV_ERROR_OUT_OF_MEMORY, hetinv_context_create(&init, &ctx));
  assert_null(ctx);
}

struct callback_log {
  int calls;
  hetinv_result_t code;
  char message[256];
};

static void record_error(void *user, hetinv_result_t code, const char *message) {
  struct callback_log *log = user;
  ++log->calls;
  log->code = code;
  snprintf(log->message, sizeof log->message, "%s", message);
}

static void error_callback_receives_code_and_message(void **state) {
  (void)state;
  struct callback_log log = {0};
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.error_fn = record_error;
  init.error_user_data = &log;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(&init, &ctx));
  hetinv_medium_t *m = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1},
                                     (int32_t[]){4, 0, 1}, &m));
  assert_int_equal(log.calls, 1);
  assert_int_equal(log.code, HETINV_ERROR_INVALID_ARGUMENT);
  assert_string_equal(log.message, hetinv_context_last_error_message(ctx));
  assert_non_null(strstr(log.message, "dims[1] (ny) is 0"));
  hetinv_context_destroy(&ctx);
}

static void messages_belong_to_their_context(void **state) {
  (void)state;
  hetinv_context_t *a = NULL, *b = NULL;
  assert_ok(hetinv_context_create(NULL, &a));
  assert_ok(hetinv_context_create(NULL, &b));
  hetinv_medium_t *m = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(a, (double[]){0, 0, 0}, (double[]){0, 1, 1},
                                     (int32_t[]){1, 1, 1}, &m));
  assert_non_null(strstr(hetinv_context_last_error_message(a), "box along x"));
  assert_string_equal(hetinv_context_last_error_message(b), "");
  assert_int_equal(hetinv_context_last_error_code(b), HETINV_SUCCESS);
  assert_int_equal(hetinv_context_last_error_code(a), HETINV_ERROR_INVALID_ARGUMENT);
  hetinv_context_destroy(&a);
  hetinv_context_destroy(&b);
}

/* An allocator that always hands out the same block, so the second context
 * lies exactly where the first one did. */
static _Alignas(max_align_t) unsigned char one_block[4096];
static void *same_block_alloc(void *user, size_t size) {
  (void)user;
  return size <= sizeof one_block ? one_block : NULL;
}
static void same_block_free(void *user, void *ptr) {
  (void)user;
  (void)ptr;
}

static void a_new_context_where_a_destroyed_one_lay_has_no_failure(void **state) {
  (void)state;
  hetinv_context_init_t init = HETINV_CONTEXT_INIT_DEFAULT;
  init.alloc_fn = same_block_alloc;
  init.free_fn = same_block_free;
  hetinv_context_t *a = NULL, *b = NULL;
  assert_ok(hetinv_context_create(&init, &a));
  hetinv_medium_t *m = NULL;
  assert_result(HETINV_ERROR_INVALID_ARGUMENT,
                hetinv_medium_create(a, (double[]){0, 0, 0}, (double[]){0, 1, 1}, (int32_t[]){1, 1, 1}, &m));
  const void *where = a;
  hetinv_context_destroy(&a);
  assert_ok(hetinv_context_create(&init, &b));
  assert_ptr_equal(b, where);
  assert_string_equal(hetinv_context_last_error_message(b), "");
  assert_int_equal(hetinv_context_last_error_code(b), HETINV_SUCCESS);
  assert_int_equal(hetinv_context_last_error_rank(b), -1);
  /* Without a context the thread's last failure is still there. */
  assert_int_equal(hetinv_context_last_error_code(NULL), HETINV_ERROR_INVALID_ARGUMENT);
  hetinv_context_destroy(&b);
}

static void *fail_on_other_thread(void *arg) {
  hetinv_context_t *ctx = arg;
  hetinv_medium_t *m = NULL;
  hetinv_medium_create(ctx, (double[]){0, 0, 0}, (double[]){1, 1, 1}, (int32_t[]){-5, 1, 1}, &m);
  return NULL;
}

static void messages_are_per_thread(void **state) {
  hetinv_context_t *ctx = *state;
  hetinv_medium_t *m = NULL;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_medium_create(ctx, NULL, NULL, NULL, &m));
  pthread_t thread;
  assert_int_equal(pthread_create(&thread, NULL, fail_on_other_thread, ctx), 0);
  assert_int_equal(pthread_join(thread, NULL), 0);
  /* The other thread's failure did not overwrite this thread's message. */
  assert_message_contains("'box_min' is NULL");
}

int main(void) {
  const struct CMUnitTest tests[] = {
      cmocka_unit_test(default_context_has_threads_and_seed_zero),
      cmocka_unit_test(initialiser_sets_threads_and_seed),
      cmocka_unit_test(context_without_mpi_is_rank_zero_of_one),
      cmocka_unit_test(destroy_accepts_null),
      cmocka_unit_test(null_output_is_rejected),
      cmocka_unit_test(too_small_init_size_is_rejected),
      cmocka_unit_test(larger_init_from_a_newer_header_is_accepted),
      cmocka_unit_test(negative_thread_count_is_rejected),
      cmocka_unit_test(allocator_hooks_are_used_and_balanced),
      cmocka_unit_test(half_an_allocator_is_rejected),
      cmocka_unit_test(allocation_failure_is_reported),
      cmocka_unit_test(error_callback_receives_code_and_message),
      cmocka_unit_test(messages_belong_to_their_context),
      cmocka_unit_test(a_new_context_where_a_destroyed_one_lay_has_no_failure),
      cmocka_unit_test_setup_teardown(messages_are_per_thread, ht_context_setup,
                                      ht_context_teardown),
  };
  return cmocka_run_group_tests(tests, NULL, NULL);
}
