/**
 * @file mpi.h
 * @brief MPI distribution of the estimator (installed only by a build with
 *        -DHETINV_WITH_MPI=ON; includes <mpi.h>).
 *
 * In an MPI build, a context created while MPI is initialised works on its
 * own dup of MPI_COMM_WORLD; created before MPI_Init (or after
 * MPI_Finalize) it is serial, rank 0 of 1, until this call gives it a
 * communicator. hetinv_context_rank() and hetinv_context_rank_count() say
 * where a process stands.
 *
 * What is distributed: hetinv_estimator_render(),
 * hetinv_estimator_gradient() and hetinv_estimator_loss_gradient() give each
 * rank a contiguous block of the measurement set's emitters (all photons of
 * an emitter stay on one rank), each rank traces its block with the
 * context's OpenMP threads, and the partial results are gathered so that
 * every rank returns the same values, standard errors, statistics, loss
 * and gradients, bitwise identical to a serial run with the same seed
 * whatever the rank count (see docs/mpi.md). These calls are collective:
 * every rank of the communicator must make them, in the same order, with
 * the same arguments (the same medium, set, map and cotangent). Each call
 * first compares, by one small reduction, a hash of what the ranks must
 * share (the estimator's tunables and gain mode, the context's seed, the
 * set's geometry, the medium's values, and the call's own arguments: the
 * cotangent, the measured values of a loss gradient): where they differ,
 * every rank fails with HETINV_ERROR_INVALID_ARGUMENT, instead of
 * returning a mix. A failure on one rank (a bad argument, out of memory) is
 * reported by every rank with that rank's result code and a copy of its
 * message ("rank 1 of 2: ..."); hetinv_context_last_error_rank() names the
 * rank it arose on, so a program prints it once. A rank that does
 * not make the call at all still leaves the others waiting: a program's
 * own steps that one rank takes alone (writing a file) are followed by
 * hetinv_context_agree(). hetinv_optimizer_run() is collective too: it
 * starts only if every rank's optimizer has the same tunables, stages and
 * progress (else HETINV_ERROR_INVALID_ARGUMENT on every rank), and its
 * checkpoint (written by rank 0), its time budget (by each rank's clock)
 * and its progress callback's stop are decided for all ranks at once.
 *
 * Threads: the library calls MPI only from the thread that calls the
 * estimator (or creates, sets up or destroys the context), never from its
 * OpenMP workers, so MPI_THREAD_FUNNELED suffices when that thread is the
 * one that initialised MPI; use MPI_THREAD_SERIALIZED if another thread
 * makes these calls. Initialise with
 * MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided). Destroy
 * every context before MPI_Finalize: a collective call on a context of
 * several ranks still alive after it fails with HETINV_ERROR_INVALID_STATE
 * (destroying it is still allowed).
 */
#ifndef HETINV_MPI_H
#define HETINV_MPI_H

/* Only MPI's C interface is used. In C++, OpenMPI's and MPICH's <mpi.h> also
 * declare their C++ bindings (deprecated in MPI-2.2, removed in MPI-3.0),
 * which need libmpi_cxx at link time (neither pkg-config's ompi-c nor
 * CMake's MPI::MPI_C links it) and warn under -Wextra: keep them out. A
 * program that uses them includes <mpi.h> before this header. */
#if defined(__cplusplus)
#  ifndef OMPI_SKIP_MPICXX
#    define OMPI_SKIP_MPICXX 1
#  endif
#  ifndef MPICH_SKIP_MPICXX
#    define MPICH_SKIP_MPICXX 1
#  endif
#endif
#include <mpi.h>

#include "hetinv/context.h"
#include "hetinv/export.h"
#include "hetinv/result.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * @brief Make the context's estimators share their work among the ranks of
 *        @p comm.
 *
 * The library dups @p comm (MPI_Comm_dup, so its messages never mix with
 * the program's) and frees the dup when the context is destroyed or given
 * another communicator; the caller keeps ownership of @p comm. Pass
 * MPI_COMM_SELF to make a context serial (rank 0 of 1) in a distributed
 * program.
 *
 * Collective over @p comm. Not thread-safe with respect to any other use of
 * the same context; estimators already created from the context use the
 * new communicator from their next call.
 * @param ctx the context.
 * @param comm an intracommunicator; its ranks must all make this call.
 * @return HETINV_SUCCESS;
 *         HETINV_ERROR_NULL_ARGUMENT if @p ctx is NULL;
 *         HETINV_ERROR_INVALID_STATE if MPI is not initialised or already
 *         finalised;
 *         HETINV_ERROR_INVALID_ARGUMENT if @p comm is MPI_COMM_NULL or an
 *         intercommunicator;
 *         HETINV_ERROR_INTERNAL if an MPI call fails (the message names it).
 *         On failure the context keeps its previous communicator.
 */
HETINV_API hetinv_result_t hetinv_context_set_mpi_comm(hetinv_context_t *ctx, MPI_Comm comm);

#ifdef __cplusplus
}
#endif

#endif /* HETINV_MPI_H */
