#include "core/comm.h"

#include <limits.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "core/alloc.h"
#include "core/context_internal.h"
#include "core/error.h"

#ifdef HETINV_WITH_MPI
#include "hetinv/mpi.h"
#endif

HETINV_API int32_t hetinv_context_rank(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  return ctx ? ctx->rank : 0;
}

HETINV_API int32_t hetinv_context_rank_count(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  return ctx ? ctx->rank_count : 1;
}

HETINV_API hetinv_result_t hetinv_context_agree(const hetinv_context_t *ctx, hetinv_result_t status) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, ctx);
  /* The status may be the program's own: no library message to carry. */
  return hv_comm_agree_status(ctx, status);
}

HETINV_API int hetinv_build_has_mpi(void) {
  HV_API_ENTER();
#ifdef HETINV_WITH_MPI
  return 1;
#else
  return 0;
#endif
}

#ifndef HETINV_WITH_MPI

hetinv_result_t hv_comm_context_init(hetinv_context_t *ctx) {
  ctx->rank = 0;
  ctx->rank_count = 1;
  return HETINV_SUCCESS;
}

void hv_comm_context_release(hetinv_context_t *ctx) { (void)ctx; }

hetinv_result_t hv_comm_agree(const hetinv_context_t *ctx, hetinv_result_t status, uint64_t key, const char *what) {
  (void)ctx;
  (void)key;
  (void)what;
  return status;
}

hetinv_result_t hv_comm_agree_status(const hetinv_context_t *ctx, hetinv_result_t status) {
  (void)ctx;
  return status;
}

hetinv_result_t hv_comm_or(const hetinv_context_t *ctx, uint32_t *flags) {
  (void)ctx;
  (void)flags;
  return HETINV_SUCCESS;
}

hetinv_result_t hv_comm_allgather(const hetinv_context_t *ctx, const double *data, size_t count,
                                  hetinv_result_t status, double **all, size_t *all_count) {
  (void)data;
  (void)count;
  *all = NULL;
  *all_count = 0;
  if (status != HETINV_SUCCESS) return status;
  return HV_FAIL(ctx, HETINV_ERROR_INTERNAL, "a collective was called in a build without MPI");
}

#else /* HETINV_WITH_MPI */

/* MPI may be used: initialised and not yet finalised. */
static bool mpi_usable(void) {
  int initialised = 0, finalised = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalised);
  return initialised && !finalised;
}

static hetinv_result_t mpi_fail(const hetinv_context_t *ctx, const char *call, int err) {
  char text[MPI_MAX_ERROR_STRING];
  int len = 0;
  if (MPI_Error_string(err, text, &len) != MPI_SUCCESS) len = 0;
  text[len < MPI_MAX_ERROR_STRING ? len : MPI_MAX_ERROR_STRING - 1] = '\0';
  return HV_FAIL(ctx, HETINV_ERROR_INTERNAL, "%s failed with MPI error %d (%s)", call, err,
                 len > 0 ? text : "no description");
}

/* Dups comm into ctx, replacing (and freeing) the context's previous dup. */
static hetinv_result_t attach(hetinv_context_t *ctx, MPI_Comm comm) {
  MPI_Comm dup = MPI_COMM_NULL;
  int err = MPI_Comm_dup(comm, &dup);
  if (err != MPI_SUCCESS) return mpi_fail(ctx, "MPI_Comm_dup", err);
  /* Failures of the library's own calls come back as codes, not aborts. */
  MPI_Comm_set_errhandler(dup, MPI_ERRORS_RETURN);
  int rank = 0, size = 1;
  MPI_Comm_rank(dup, &rank);
  MPI_Comm_size(dup, &size);
  hv_comm_context_release(ctx);
  ctx->comm = dup;
  ctx->rank = rank;
  ctx->rank_count = size;
  return HETINV_SUCCESS;
}

hetinv_result_t hv_comm_context_init(hetinv_context_t *ctx) {
  ctx->comm = MPI_COMM_NULL;
  ctx->rank = 0;
  ctx->rank_count = 1;
  if (!mpi_usable()) return HETINV_SUCCESS; /* serial: rank 0 of 1 */
  return attach(ctx, MPI_COMM_WORLD);
}

void hv_comm_context_release(hetinv_context_t *ctx) {
  if (ctx->comm != MPI_COMM_NULL && mpi_usable()) MPI_Comm_free(&ctx->comm);
  ctx->comm = MPI_COMM_NULL;
  ctx->rank = 0;
  ctx->rank_count = 1;
}

HETINV_API hetinv_result_t hetinv_context_set_mpi_comm(hetinv_context_t *ctx, MPI_Comm comm) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, ctx);
  if (!mpi_usable()) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE,
                   "MPI is not initialised (or already finalised); call MPI_Init_thread first");
  }
  if (comm == MPI_COMM_NULL) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT, "comm is MPI_COMM_NULL");
  }
  int inter = 0;
  int err = MPI_Comm_test_inter(comm, &inter);
  if (err != MPI_SUCCESS) return mpi_fail(ctx, "MPI_Comm_test_inter", err);
  if (inter) {
    return HV_FAIL(ctx, HETINV_ERROR_INVALID_ARGUMENT,
                   "comm is an intercommunicator; an intracommunicator is needed");
  }
  return attach(ctx, comm);
}

/* The first failing rank's code and, where `carry`, its message, sent to
 * every rank; returns what this rank records. */
static hetinv_result_t take_failure(const hetinv_context_t *ctx, hetinv_result_t status, int first, bool carry) {
  struct {
    int32_t code;
    char text[HV_MESSAGE_CAPACITY];
  } f = {status, ""};
  if (ctx->rank == first && carry) {
    const char *mine = hv_last_failure(ctx, status);
    if (mine != NULL) snprintf(f.text, sizeof f.text, "%s", mine);
  }
  /* The text only when there is one: a program's agreement sends 4 bytes. */
  int err = MPI_Bcast(&f, carry ? (int)sizeof f : (int)sizeof f.code, MPI_BYTE, first, ctx->comm);
  if (err != MPI_SUCCESS) return mpi_fail(ctx, "MPI_Bcast", err);
  if (status != HETINV_SUCCESS) return status;
  hetinv_result_t code = (hetinv_result_t)f.code;
  f.text[sizeof f.text - 1] = '\0';
  if (f.text[0] == '\0') {
    return hv_fail_from_rank(ctx, code, first, __func__, "rank %d of %d failed with %s (its own message says why)",
                             first, ctx->rank_count, hetinv_result_name(code));
  }
  /* "hetinv_estimator_render: 'values' is NULL" from a rank in the same
   * call: its function's name is this message's prefix already. */
  const char *text = f.text, *entry = hv_api_entry;
  size_t n = entry != NULL ? strlen(entry) : 0;
  if (n > 0 && strncmp(text, entry, n) == 0 && text[n] == ':' && text[n + 1] == ' ') text += n + 2;
  return hv_fail_from_rank(ctx, code, first, __func__, "rank %d of %d: %s", first, ctx->rank_count, text);
}

/* A distributed context used after MPI_Finalize: MPI would abort the
 * process; the header asks for contexts to be destroyed before it. */
static hetinv_result_t finalised(const hetinv_context_t *ctx) {
  return HV_FAIL(ctx, HETINV_ERROR_INVALID_STATE,
                 "MPI was finalised while this context of %d ranks was alive; destroy contexts before "
                 "MPI_Finalize", ctx->rank_count);
}

static hetinv_result_t agree(const hetinv_context_t *ctx, hetinv_result_t status, uint64_t key, const char *what,
                             bool carry) {
  int ranks = ctx->rank_count;
  if (ranks == 1) return status;
  if (!mpi_usable()) return finalised(ctx);
  /* One reduction by maximum: ranks − (first failing rank), and the key
   * and its complement, whose maxima equal a rank's own only if every
   * rank's key is its own. */
  uint64_t mine[3] = {status != HETINV_SUCCESS ? (uint64_t)(ranks - ctx->rank) : 0, key, ~key}, all[3];
  int err = MPI_Allreduce(mine, all, 3, MPI_UINT64_T, MPI_MAX, ctx->comm);
  if (err != MPI_SUCCESS) return mpi_fail(ctx, "MPI_Allreduce", err);
  if (all[0] != 0) return take_failure(ctx, status, ranks - (int)all[0], carry);
  if (all[1] != key || all[2] != ~key) {
    /* Every rank finds it; reported as rank 0's, so that it is printed once. */
    return hv_fail_from_rank(ctx, HETINV_ERROR_INVALID_ARGUMENT, 0, __func__,
                             "the %d ranks' calls differ in %s; every rank must pass the same", ranks, what);
  }
  return HETINV_SUCCESS;
}

hetinv_result_t hv_comm_agree(const hetinv_context_t *ctx, hetinv_result_t status, uint64_t key, const char *what) {
  return agree(ctx, status, key, what, true);
}

hetinv_result_t hv_comm_agree_status(const hetinv_context_t *ctx, hetinv_result_t status) {
  /* Key 0: a rank here met another rank's agreement at another place. */
  return agree(ctx, status, 0, "the step of the program they are at (one rank's agreement met another "
               "rank's call elsewhere)", false);
}

hetinv_result_t hv_comm_or(const hetinv_context_t *ctx, uint32_t *flags) {
  if (ctx->rank_count == 1) return HETINV_SUCCESS;
  if (!mpi_usable()) return finalised(ctx);
  uint32_t all = 0;
  int err = MPI_Allreduce(flags, &all, 1, MPI_UINT32_T, MPI_BOR, ctx->comm);
  if (err != MPI_SUCCESS) return mpi_fail(ctx, "MPI_Allreduce", err);
  *flags = all;
  return HETINV_SUCCESS;
}

hetinv_result_t hv_comm_allgather(const hetinv_context_t *ctx, const double *data, size_t count,
                                  hetinv_result_t status, double **all, size_t *all_count) {
  *all = NULL;
  *all_count = 0;
  int ranks = ctx->rank_count;
  int64_t *sizes = hv_calloc(ctx, (size_t)ranks, sizeof(int64_t));
  int *counts = hv_calloc(ctx, (size_t)ranks, sizeof(int));
  int *displs = hv_calloc(ctx, (size_t)ranks, sizeof(int));
  if (status == HETINV_SUCCESS && (sizes == NULL || counts == NULL || displs == NULL)) {
    status = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate the counts of %d ranks",
                     ranks);
  }
  hetinv_result_t r = hv_comm_agree(ctx, status, 0, "nothing");
  int64_t mine = (int64_t)count, total = 0;
  if (r == HETINV_SUCCESS) {
    int err = MPI_Allgather(&mine, 1, MPI_INT64_T, sizes, 1, MPI_INT64_T, ctx->comm);
    if (err != MPI_SUCCESS) r = mpi_fail(ctx, "MPI_Allgather", err);
  }
  for (int k = 0; r == HETINV_SUCCESS && k < ranks; ++k) total += sizes[k];
  if (r == HETINV_SUCCESS && total > INT_MAX) {
    /* The same on every rank: all stop here. */
    r = HV_FAIL(ctx, HETINV_ERROR_UNSUPPORTED,
                "the ranks' partial results hold %lld doubles; MPI_Allgatherv takes at most %d",
                (long long)total, INT_MAX);
  }
  double *buf = NULL;
  if (r == HETINV_SUCCESS && total > 0) {
    for (int k = 0, at = 0; k < ranks; ++k) {
      counts[k] = (int)sizes[k];
      displs[k] = at;
      at += counts[k];
    }
    buf = hv_calloc(ctx, (size_t)total, sizeof(double));
    hetinv_result_t mine_r = HETINV_SUCCESS;
    if (buf == NULL) {
      mine_r = HV_FAIL(ctx, HETINV_ERROR_OUT_OF_MEMORY,
                       "cannot allocate %lld doubles for the gathered results", (long long)total);
    }
    r = hv_comm_agree(ctx, mine_r, 0, "nothing");
  }
  if (r == HETINV_SUCCESS && total > 0) {
    int err = MPI_Allgatherv(data, (int)count, MPI_DOUBLE, buf, counts, displs, MPI_DOUBLE, ctx->comm);
    if (err != MPI_SUCCESS) r = mpi_fail(ctx, "MPI_Allgatherv", err);
  }
  hv_free(ctx, sizes);
  hv_free(ctx, counts);
  hv_free(ctx, displs);
  if (r != HETINV_SUCCESS) {
    hv_free(ctx, buf);
    return r;
  }
  *all = buf;
  *all_count = (size_t)total;
  return HETINV_SUCCESS;
}

#endif /* HETINV_WITH_MPI */
