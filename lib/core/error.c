#include "core/error.h"

#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "core/context_internal.h"

/* One record per thread: the last failure, whichever context it came from
 * (its address and serial: a later context may reuse the address), and the
 * rank it arose on. */
static _Thread_local struct {
  const hetinv_context_t *ctx;
  uint64_t serial;
  hetinv_result_t code;
  int32_t rank;
  char message[HV_MESSAGE_CAPACITY];
} last_error;

_Thread_local const char *hv_api_entry HV_API_ENTRY_TLS;

#if defined(__GNUC__)
__attribute__((format(printf, 5, 0))) /* a va_list wrapper: its callers' formats are checked */
#endif
static hetinv_result_t record(const hetinv_context_t *ctx, hetinv_result_t code, int32_t rank, const char *func,
                              const char *fmt, va_list args) {
  const char *name = hv_api_entry != NULL ? hv_api_entry : func;
  int prefix = snprintf(last_error.message, sizeof last_error.message, "%s: ", name);
  if (prefix < 0 || (size_t)prefix >= sizeof last_error.message) prefix = 0;
  vsnprintf(last_error.message + prefix, sizeof last_error.message - (size_t)prefix, fmt, args);
  last_error.ctx = ctx;
  last_error.serial = ctx != NULL ? ctx->serial : 0;
  last_error.code = code;
  last_error.rank = rank;
  if (ctx != NULL && ctx->error_fn != NULL) {
    const char *entry = hv_api_suspend();
    ctx->error_fn(ctx->error_user_data, code, last_error.message);
    hv_api_resume(entry);
  }
  return code;
}

hetinv_result_t hv_fail(const hetinv_context_t *ctx, hetinv_result_t code, const char *func,
                        const char *fmt, ...) {
  va_list args;
  va_start(args, fmt);
  record(ctx, code, ctx != NULL ? ctx->rank : 0, func, fmt, args);
  va_end(args);
  return code;
}

hetinv_result_t hv_fail_from_rank(const hetinv_context_t *ctx, hetinv_result_t code, int32_t origin,
                                  const char *func, const char *fmt, ...) {
  va_list args;
  va_start(args, fmt);
  record(ctx, code, origin, func, fmt, args);
  va_end(args);
  return code;
}

/* Whether the thread's record belongs to ctx (a live context). */
static bool recorded_for(const hetinv_context_t *ctx) {
  return ctx == last_error.ctx && (ctx == NULL || ctx->serial == last_error.serial);
}

const char *hv_last_failure(const hetinv_context_t *ctx, hetinv_result_t code) {
  if (last_error.code != code || !recorded_for(ctx) || code == HETINV_SUCCESS) return NULL;
  return last_error.message;
}

HETINV_API const char *hetinv_context_last_error_message(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  if (last_error.code == HETINV_SUCCESS) return "";
  if (ctx != NULL && !recorded_for(ctx)) return "";
  return last_error.message;
}

HETINV_API hetinv_result_t hetinv_context_last_error_code(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  if (ctx != NULL && !recorded_for(ctx)) return HETINV_SUCCESS;
  return last_error.code;
}

HETINV_API int32_t hetinv_context_last_error_rank(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  if (last_error.code == HETINV_SUCCESS) return -1;
  if (ctx != NULL && !recorded_for(ctx)) return -1;
  return last_error.rank;
}
