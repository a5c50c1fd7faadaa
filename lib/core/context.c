#include <stdatomic.h>
#include <stddef.h>
#include <stdlib.h>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "core/alloc.h"
#include "core/comm.h"
#include "core/context_internal.h"
#include "core/error.h"

/* The members of the first published hetinv_context_init_t; a caller's
 * struct must cover at least these. Later members are read only when
 * init->size says the caller's struct has them. */
#define HV_INIT_V1_SIZE (offsetof(hetinv_context_init_t, seed) + sizeof(uint64_t))

static atomic_uint_fast64_t next_serial = 1; /* hetinv_context_t's serial */

HETINV_API hetinv_result_t hetinv_context_create(const hetinv_context_init_t *init,
                                                 hetinv_context_t **out) {
  HV_API_ENTER();
  HV_CHECK_NULL(NULL, out);
  *out = NULL;
  hetinv_context_init_t opts = HETINV_CONTEXT_INIT_DEFAULT;
  if (init != NULL) {
    if (init->size < HV_INIT_V1_SIZE) {
      return HV_FAIL(NULL, HETINV_ERROR_INVALID_ARGUMENT,
                     "init->size is %zu; it must be at least %zu (use HETINV_CONTEXT_INIT_DEFAULT)",
                     init->size, (size_t)HV_INIT_V1_SIZE);
    }
    opts = *init; /* all members of this version are within HV_INIT_V1_SIZE */
  }
  if ((opts.alloc_fn == NULL) != (opts.free_fn == NULL)) {
    return HV_FAIL(NULL, HETINV_ERROR_INVALID_ARGUMENT,
                   "alloc_fn and free_fn must both be set or both be NULL (alloc_fn is %s, free_fn is %s)",
                   opts.alloc_fn ? "set" : "NULL", opts.free_fn ? "set" : "NULL");
  }
  if (opts.thread_count < 0 || opts.thread_count > HETINV_MAX_THREADS) {
    return HV_FAIL(NULL, HETINV_ERROR_INVALID_ARGUMENT,
                   "thread_count is %d; it must be in [0, HETINV_MAX_THREADS (%d)] "
                   "(0 means all available)", (int)opts.thread_count, HETINV_MAX_THREADS);
  }
  hetinv_context_t proto = {
      .alloc_fn = opts.alloc_fn,
      .free_fn = opts.free_fn,
      .alloc_user_data = opts.alloc_user_data,
      .error_fn = opts.error_fn,
      .error_user_data = opts.error_user_data,
      .thread_count = opts.thread_count,
      .seed = opts.seed,
      .serial = atomic_fetch_add(&next_serial, 1),
  };
  if (proto.thread_count == 0) {
#ifdef _OPENMP
    proto.thread_count = omp_get_max_threads();
    if (proto.thread_count > HETINV_MAX_THREADS) proto.thread_count = HETINV_MAX_THREADS;
#else
    proto.thread_count = 1;
#endif
  }
  hetinv_context_t *ctx = hv_alloc(&proto, sizeof *ctx);
  if (ctx == NULL) {
    return HV_FAIL(&proto, HETINV_ERROR_OUT_OF_MEMORY, "cannot allocate %zu bytes", sizeof *ctx);
  }
  *ctx = proto;
  hetinv_result_t r = hv_comm_context_init(ctx);
  if (r != HETINV_SUCCESS) {
    hv_free(&proto, ctx);
    return r;
  }
  *out = ctx;
  return HETINV_SUCCESS;
}

HETINV_API void hetinv_context_destroy(hetinv_context_t **ctx) {
  HV_API_ENTER();
  if (ctx == NULL || *ctx == NULL) return;
  hv_comm_context_release(*ctx);
  hetinv_context_t copy = **ctx; /* the hooks outlive the block they free */
  hv_free(&copy, *ctx);
  *ctx = NULL;
}

HETINV_API int32_t hetinv_context_thread_count(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  return ctx ? ctx->thread_count : 0;
}

HETINV_API uint64_t hetinv_context_seed(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  return ctx ? ctx->seed : 0;
}
