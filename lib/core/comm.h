/* The context's communicator: which rank this process is, and the few
 * collectives the estimator needs. Without MPI (or with MPI not initialised
 * when the context was made) every context is rank 0 of 1 and nothing here
 * communicates. */
#ifndef HV_COMM_H
#define HV_COMM_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/context.h"
#include "hetinv/result.h"

/* Called by hetinv_context_create on the new context: attaches a dup of
 * MPI_COMM_WORLD when MPI is initialised (MPI build only). */
hetinv_result_t hv_comm_context_init(hetinv_context_t *ctx);
/* Called by hetinv_context_destroy: frees the context's dup, if any. */
void hv_comm_context_release(hetinv_context_t *ctx);

/* Items [*lo, *hi) of n that rank `rank` of `ranks` owns: contiguous blocks
 * in rank order, so that concatenating every rank's block in rank order
 * gives the items in order. */
static inline void hv_comm_block(int64_t n, int32_t rank, int32_t ranks, int64_t *lo, int64_t *hi) {
  *lo = n * rank / ranks;
  *hi = n * (rank + 1) / ranks;
}

/* Collective over the context's communicator when it has several ranks;
 * with one rank it only returns `status`. Every rank passes its status so
 * far and `key`, a hash of the arguments every rank must pass alike. Every
 * rank returns the code of the first failing rank (in rank order): a
 * failing rank keeps its own message, the others record a copy of it
 * ("rank 1 of 2: ...", hetinv_context_last_error_rank() 1) where the
 * failing rank's last message is that failure's, else one naming it. If
 * none failed but the keys differ, every rank fails with
 * HETINV_ERROR_INVALID_ARGUMENT naming `what` (the keys' content). A rank
 * that fails before a collective must still come here, or the others wait
 * for it forever. */
hetinv_result_t hv_comm_agree(const hetinv_context_t *ctx, hetinv_result_t status, uint64_t key, const char *what);

/* hv_comm_agree for a status that may be the caller's own, not a library
 * failure (hetinv_context_agree): the others' message names the failing
 * rank and its code, never a text of that rank's that may be stale. */
hetinv_result_t hv_comm_agree_status(const hetinv_context_t *ctx, hetinv_result_t status);

/* Collective like hv_comm_agree: *flags becomes the bitwise OR of every
 * rank's flags (one rank: unchanged), so that a decision one rank takes
 * (a stop) is taken by all. */
hetinv_result_t hv_comm_or(const hetinv_context_t *ctx, uint32_t *flags);

/* Collective over the context's communicator (only call with rank_count > 1).
 * Every rank contributes `count` doubles and its status so far. If every
 * status is HETINV_SUCCESS, *all receives the concatenation of every rank's
 * doubles in rank order (allocated with the context's hooks; the caller
 * frees it) and *all_count its length. Otherwise every rank returns the code
 * of the first failing rank: a failing rank keeps its own message, the
 * others record one naming the failing rank. */
hetinv_result_t hv_comm_allgather(const hetinv_context_t *ctx, const double *data, size_t count,
                                  hetinv_result_t status, double **all, size_t *all_count);

#endif
