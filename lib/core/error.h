/* Recording failures: the per-thread message, the context's callback. */
#ifndef HV_ERROR_H
#define HV_ERROR_H

#include "hetinv/context.h"
#include "hetinv/result.h"

/* Formats the message, records it (with code and context) for the calling
 * thread, calls the context's error callback, and returns @p code, so that
 * a failing path reads `return HV_FAIL(ctx, CODE, "...", ...);`. */
#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
hetinv_result_t hv_fail(const hetinv_context_t *ctx, hetinv_result_t code, const char *func,
                        const char *fmt, ...);

/* Prefixes the message with the public function's name. */
#define HV_FAIL(ctx, code, ...) hv_fail((ctx), (code), __func__, __VA_ARGS__)

/* Shorthand for the ubiquitous NULL-argument check. */
#define HV_CHECK_NULL(ctx, ptr) \
  do { \
    if ((ptr) == NULL) return HV_FAIL((ctx), HETINV_ERROR_NULL_ARGUMENT, "'%s' is NULL", #ptr); \
  } while (0)

#endif
