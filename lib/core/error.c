#include "core/error.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "core/context_internal.h"

enum { HV_MESSAGE_CAPACITY = 1024 };

/* One record per thread: the last failure, whichever context it came from. */
static _Thread_local struct {
  const hetinv_context_t *ctx;
  hetinv_result_t code;
  char message[HV_MESSAGE_CAPACITY];
} last_error;

_Thread_local const char *hv_api_entry HV_API_ENTRY_TLS;

hetinv_result_t hv_fail(const hetinv_context_t *ctx, hetinv_result_t code, const char *func,
                        const char *fmt, ...) {
  const char *name = hv_api_entry != NULL ? hv_api_entry : func;
  int prefix = snprintf(last_error.message, sizeof last_error.message, "%s: ", name);
  if (prefix < 0 || (size_t)prefix >= sizeof last_error.message) prefix = 0;
  va_list args;
  va_start(args, fmt);
  vsnprintf(last_error.message + prefix, sizeof last_error.message - (size_t)prefix, fmt, args);
  va_end(args);
  last_error.ctx = ctx;
  last_error.code = code;
  if (ctx != NULL && ctx->error_fn != NULL) {
    const char *entry = hv_api_suspend();
    ctx->error_fn(ctx->error_user_data, code, last_error.message);
    hv_api_resume(entry);
  }
  return code;
}

HETINV_API const char *hetinv_context_last_error_message(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  if (last_error.code == HETINV_SUCCESS) return "";
  if (ctx != NULL && ctx != last_error.ctx) return "";
  return last_error.message;
}

HETINV_API hetinv_result_t hetinv_context_last_error_code(const hetinv_context_t *ctx) {
  HV_API_ENTER();
  if (ctx != NULL && ctx != last_error.ctx) return HETINV_SUCCESS;
  return last_error.code;
}
