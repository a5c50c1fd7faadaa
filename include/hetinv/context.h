/**
 * @file context.h
 * @brief The context: allocator, error reporting, threads and base seed.
 *
 * Every other libhetinv object is created from a context and must be
 * destroyed before it. A context may be used from several threads at once
 * (its state is read-only after creation); the objects created from it have
 * their own rules, stated in their headers.
 *
 * Distributed runs: in a build with MPI (hetinv_build_has_mpi() is 1), a
 * context created while MPI is initialised works on a dup of
 * MPI_COMM_WORLD (or on the communicator given to
 * hetinv_context_set_mpi_comm(), declared in hetinv/mpi.h), and the
 * estimator shares its work among the communicator's ranks. Creating and
 * destroying such a context are then collective over that communicator.
 * Otherwise a context is rank 0 of 1 and never communicates.
 */
#ifndef HETINV_CONTEXT_H
#define HETINV_CONTEXT_H

#include <stddef.h>
#include <stdint.h>

#include "hetinv/export.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Opaque context handle. */
typedef struct hetinv_context hetinv_context_t;

/**
 * @brief Allocation hook: return @p size bytes aligned for any object type
 *        (as malloc does), or NULL on failure. @p size is never 0.
 */
typedef void *(*hetinv_alloc_fn)(void *user_data, size_t size);
/** @brief Release hook: free memory returned by the matching alloc hook; @p ptr is never NULL. */
typedef void (*hetinv_free_fn)(void *user_data, void *ptr);

/**
 * @brief Error callback, called on the failing thread after the message has
 *        been recorded. @p message is valid only during the call.
 *        It may be called from several threads at once.
 */
typedef void (*hetinv_error_fn)(void *user_data, hetinv_result_t code, const char *message);

/**
 * Largest hetinv_context_init_t::thread_count. OpenMP runtimes fail (or
 * abort) when asked for tens of thousands of threads, and the estimator
 * keeps a tally per thread; no machine this library targets has more
 * hardware threads than this.
 */
#define HETINV_MAX_THREADS 1024

/**
 * @brief Creation parameters of a context.
 *
 * Start from HETINV_CONTEXT_INIT_DEFAULT and change what you need. The first
 * member is the struct's own size, so later versions can append members
 * without breaking programs compiled against this header: the library reads
 * only the members that @c size covers.
 */
typedef struct hetinv_context_init {
  size_t size;                /**< sizeof(hetinv_context_init_t); set by HETINV_CONTEXT_INIT_DEFAULT */
  hetinv_alloc_fn alloc_fn;   /**< NULL: malloc. Must be set together with free_fn. */
  hetinv_free_fn free_fn;     /**< NULL: free. */
  void *alloc_user_data;      /**< passed to alloc_fn and free_fn */
  hetinv_error_fn error_fn;   /**< NULL: no callback (messages are still recorded) */
  void *error_user_data;      /**< passed to error_fn */
  int32_t thread_count;       /**< worker threads for parallel work, in [0, HETINV_MAX_THREADS]; 0: all the OpenMP runtime offers (at most HETINV_MAX_THREADS) */
  uint64_t seed;              /**< base seed of every random stream derived from this context */
} hetinv_context_init_t;

/** Default initialiser: malloc/free, no callback, all threads, seed 0. */
#define HETINV_CONTEXT_INIT_DEFAULT \
  { sizeof(hetinv_context_init_t), NULL, NULL, NULL, NULL, NULL, 0, 0 }

/**
 * @brief Create a context.
 * @param init creation parameters, or NULL for HETINV_CONTEXT_INIT_DEFAULT.
 *        Read during the call only.
 * @param[out] out receives the new context; set to NULL on failure.
 * @return HETINV_SUCCESS;
 *         HETINV_ERROR_NULL_ARGUMENT if @p out is NULL;
 *         HETINV_ERROR_INVALID_ARGUMENT if init->size is smaller than the
 *         first version of the struct, thread_count < 0 or
 *         > HETINV_MAX_THREADS, or exactly one of
 *         alloc_fn / free_fn is set;
 *         HETINV_ERROR_OUT_OF_MEMORY;
 *         HETINV_ERROR_INTERNAL if, in a build with MPI and with MPI
 *         initialised, MPI_Comm_dup of MPI_COMM_WORLD fails.
 * Thread-safe; in a build with MPI and with MPI initialised, collective
 * over MPI_COMM_WORLD (every rank creates its contexts in the same order).
 */
HETINV_API hetinv_result_t hetinv_context_create(const hetinv_context_init_t *init,
                                                 hetinv_context_t **out);

/**
 * @brief Destroy a context and set @p *ctx to NULL.
 *
 * Every object created from the context must have been destroyed first.
 * @param ctx address of the handle; NULL or a NULL handle is a no-op.
 * Not thread-safe with respect to other uses of the same context.
 */
HETINV_API void hetinv_context_destroy(hetinv_context_t **ctx);

/**
 * @brief Number of worker threads parallel calls of this context use
 *        (thread_count of the initialiser, or the OpenMP maximum if it was 0).
 * @param ctx the context; NULL gives 0. Thread-safe.
 */
HETINV_API int32_t hetinv_context_thread_count(const hetinv_context_t *ctx);

/**
 * @brief This process's rank in the context's communicator.
 *
 * 0 in a build without MPI, when MPI was not initialised at the context's
 * creation, or on the first rank of a distributed run. Every rank computes
 * the same estimator results, so a program that writes files can write them
 * on rank 0 only.
 * @param ctx the context; NULL gives 0. Thread-safe.
 * @return the rank, in [0, hetinv_context_rank_count(ctx)).
 */
HETINV_API int32_t hetinv_context_rank(const hetinv_context_t *ctx);

/**
 * @brief Number of ranks (processes) the context's estimators share their
 *        work with.
 * @param ctx the context; NULL gives 1. Thread-safe.
 * @return 1 in a build without MPI or when MPI was not initialised at the
 *         context's creation; otherwise the size of its communicator.
 */
HETINV_API int32_t hetinv_context_rank_count(const hetinv_context_t *ctx);

/**
 * @brief Make every rank learn whether any failed: collective over the
 *        context's ranks (one rank: returns @p status).
 *
 * For a distributed program's own steps that one rank takes alone, such as
 * rank 0 writing a file: every rank passes its status, and every rank
 * returns the code of the first rank (in rank order) that failed, or
 * HETINV_SUCCESS. A failing rank keeps its own message; the others record
 * one naming it (not its text: the status may be the program's own, which
 * no library message describes); hetinv_context_last_error_rank() gives
 * its rank. Call it after such a step and before the next collective
 * call (an estimator's render or gradient, an optimizer's run), or a rank
 * that stopped alone leaves the others waiting for it forever.
 * @param ctx the context.
 * @param status this rank's result so far.
 * @return the agreed result; HETINV_ERROR_NULL_ARGUMENT for a NULL context
 *         (not collective); HETINV_ERROR_INTERNAL if MPI fails.
 */
HETINV_API hetinv_result_t hetinv_context_agree(const hetinv_context_t *ctx, hetinv_result_t status);

/**
 * @brief Whether this library was built with MPI (-DHETINV_WITH_MPI=ON),
 *        i.e. whether hetinv/mpi.h and hetinv_context_set_mpi_comm() exist.
 * @return 1 with MPI, 0 without. Thread-safe.
 */
HETINV_API int hetinv_build_has_mpi(void);

/**
 * @brief Base seed of the context's random streams.
 * @param ctx the context; NULL gives 0. Thread-safe.
 */
HETINV_API uint64_t hetinv_context_seed(const hetinv_context_t *ctx);

/**
 * @brief Detailed message of the last failing call on the calling thread.
 *
 * Messages name the offending value and where it is, e.g.
 * "hetinv_medium_set_grid: sigma_s of voxel (12, 4, 0) is -0.3; it must be >= 0".
 * A successful call does not clear the message.
 * @param ctx the context the failing call was made on, or NULL for the last
 *        failure on this thread whatever its context (use NULL after a failed
 *        hetinv_context_create). If the thread's last failure belongs to
 *        another context, the result is "" (a destroyed one included, even
 *        where the new context was allocated at its address).
 * @return a string owned by the library, valid until the next failing call
 *         on this thread; never NULL ("" when there was no failure).
 * Thread-safe: each thread has its own message.
 */
HETINV_API const char *hetinv_context_last_error_message(const hetinv_context_t *ctx);

/**
 * @brief Result code of the last failing call on the calling thread, with the
 *        same context rule as hetinv_context_last_error_message();
 *        HETINV_SUCCESS when there is none. Thread-safe.
 */
HETINV_API hetinv_result_t hetinv_context_last_error_code(const hetinv_context_t *ctx);

/**
 * @brief The MPI rank the last failure on the calling thread arose on, with
 *        the same context rule as hetinv_context_last_error_message().
 *
 * A collective call (a render, a gradient, an optimizer's run) that fails
 * on one rank fails on every rank: the failing rank records its own message
 * and its own rank, the others a copy of its message ("rank 1 of 2: ...")
 * and its rank. A failure every rank detects alike (the ranks' calls
 * differ) is reported as rank 0's. So a distributed program prints a
 * failure once by printing it only where this equals hetinv_context_rank().
 * Without MPI, or with one rank, every failure is rank 0's.
 * @param ctx the context the failing call was made on, or NULL.
 * @return the rank, or -1 when there is no failure to report. Thread-safe.
 * Added in 0.3.
 */
HETINV_API int32_t hetinv_context_last_error_rank(const hetinv_context_t *ctx);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_CONTEXT_H */
