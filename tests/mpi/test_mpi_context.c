/* hetinv_context_set_mpi_comm and the default communicator (MPI build;
 * run under mpirun with any rank count). */
#include <hetinv/mpi.h>

#include "test_support.h"

static void set_comm_before_mpi_init_is_invalid_state(void **state) {
  (void)state;
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(NULL, &ctx));
  assert_int_equal(hetinv_context_rank_count(ctx), 1); /* made before MPI_Init: serial */
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_context_set_mpi_comm(ctx, MPI_COMM_WORLD));
  assert_message_contains("MPI is not initialised");
  hetinv_context_destroy(&ctx);
}

static void bad_arguments_are_rejected(void **state) {
  (void)state;
  assert_result(HETINV_ERROR_NULL_ARGUMENT, hetinv_context_set_mpi_comm(NULL, MPI_COMM_WORLD));
  assert_message_contains("'ctx' is NULL");
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(NULL, &ctx));
  assert_result(HETINV_ERROR_INVALID_ARGUMENT, hetinv_context_set_mpi_comm(ctx, MPI_COMM_NULL));
  assert_message_contains("comm is MPI_COMM_NULL");
  /* The context keeps its communicator. */
  int ranks = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  assert_int_equal(hetinv_context_rank_count(ctx), ranks);
  hetinv_context_destroy(&ctx);
}

static void default_is_world_and_self_makes_it_serial(void **state) {
  (void)state;
  int rank = 0, ranks = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  assert_int_equal(hetinv_build_has_mpi(), 1);
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(NULL, &ctx));
  assert_int_equal(hetinv_context_rank(ctx), rank);
  assert_int_equal(hetinv_context_rank_count(ctx), ranks);
  assert_ok(hetinv_context_set_mpi_comm(ctx, MPI_COMM_SELF));
  assert_int_equal(hetinv_context_rank(ctx), 0);
  assert_int_equal(hetinv_context_rank_count(ctx), 1);
  assert_ok(hetinv_context_set_mpi_comm(ctx, MPI_COMM_WORLD));
  assert_int_equal(hetinv_context_rank(ctx), rank);
  hetinv_context_destroy(&ctx);
}

/* The context works on its own dup: the caller may free the communicator
 * it passed. */
static void communicator_survives_caller_freeing_its_own(void **state) {
  (void)state;
  MPI_Comm mine = MPI_COMM_NULL;
  MPI_Comm_dup(MPI_COMM_WORLD, &mine);
  hetinv_context_t *ctx = NULL;
  assert_ok(hetinv_context_create(NULL, &ctx));
  assert_ok(hetinv_context_set_mpi_comm(ctx, mine));
  MPI_Comm_free(&mine); /* the context holds its own dup */
  int ranks = 0;
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  assert_int_equal(hetinv_context_rank_count(ctx), ranks);
  hetinv_context_destroy(&ctx);
}

/* A context of several ranks still alive at MPI_Finalize (the header asks
 * for contexts to be destroyed first): its next collective aborted the
 * process inside MPI; now it fails with a message, and it can be destroyed. */
static hetinv_context_t *alive_at_finalize;

static void a_context_alive_at_finalize_fails_its_collectives(void **state) {
  (void)state;
  assert_result(HETINV_ERROR_INVALID_STATE, hetinv_context_agree(alive_at_finalize, HETINV_SUCCESS));
  assert_message_contains("MPI was finalised while this context of 2 ranks was alive");
  hetinv_context_destroy(&alive_at_finalize);
}

int main(int argc, char **argv) {
  const struct CMUnitTest before[] = {
      cmocka_unit_test(set_comm_before_mpi_init_is_invalid_state),
  };
  const struct CMUnitTest during[] = {
      cmocka_unit_test(bad_arguments_are_rejected),
      cmocka_unit_test(default_is_world_and_self_makes_it_serial),
      cmocka_unit_test(communicator_survives_caller_freeing_its_own),
  };
  int failed = cmocka_run_group_tests_name("before MPI_Init", before, NULL, NULL);
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  failed += cmocka_run_group_tests_name("with MPI", during, NULL, NULL);
  int any = 0, ranks = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (ranks == 2 && hetinv_context_create(NULL, &alive_at_finalize) != HETINV_SUCCESS) any = 1;
  MPI_Finalize();
  if (alive_at_finalize != NULL) {
    const struct CMUnitTest after[] = {
        cmocka_unit_test(a_context_alive_at_finalize_fails_its_collectives),
    };
    any += cmocka_run_group_tests_name("after MPI_Finalize", after, NULL, NULL);
  }
  return any != 0;
}
