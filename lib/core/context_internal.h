/* The context's fields, shared by the library's subsystems (never installed). */
#ifndef HV_CONTEXT_INTERNAL_H
#define HV_CONTEXT_INTERNAL_H

#include "hetinv/context.h"

#ifdef HETINV_WITH_MPI
#include <mpi.h>
#endif

struct hetinv_context {
  hetinv_alloc_fn alloc_fn;
  hetinv_free_fn free_fn;
  void *alloc_user_data;
  hetinv_error_fn error_fn;
  void *error_user_data;
  int32_t thread_count; /* resolved: always >= 1 */
  uint64_t seed;
  /* Which process of a distributed run this context is (core/comm.h):
   * 0 of 1 unless an MPI communicator is attached. */
  int32_t rank, rank_count;
  /* Unique among the process's contexts (never 0): a context created where
   * a destroyed one lay is told apart from it by the thread's last-failure
   * record (core/error.c), which would otherwise match by address alone. */
  uint64_t serial;
#ifdef HETINV_WITH_MPI
  MPI_Comm comm; /* the library's own dup, or MPI_COMM_NULL */
#endif
};

#endif
