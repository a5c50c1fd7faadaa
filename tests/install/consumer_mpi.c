/* A program built against an installed libhetinv with MPI: hetinv/mpi.h
 * brings <mpi.h>, and a context can be given a communicator. */
#include <hetinv/hetinv.h>
#include <hetinv/mpi.h>
#include <stdio.h>

int main(int argc, char **argv) {
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  hetinv_context_t *ctx = NULL;
  int ok = hetinv_build_has_mpi() == 1 && hetinv_context_create(NULL, &ctx) == HETINV_SUCCESS &&
           hetinv_context_set_mpi_comm(ctx, MPI_COMM_SELF) == HETINV_SUCCESS &&
           hetinv_context_rank(ctx) == 0 && hetinv_context_rank_count(ctx) == 1;
  if (!ok) fprintf(stderr, "failed: %s\n", hetinv_context_last_error_message(NULL));
  else printf("mpi consumer ok: libhetinv %s\n", hetinv_version_string());
  hetinv_context_destroy(&ctx);
  MPI_Finalize();
  return ok ? 0 : 1;
}
