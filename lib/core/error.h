/* Recording failures: the per-thread message, the context's callback, and
 * the public function a failure is attributed to. */
#ifndef HV_ERROR_H
#define HV_ERROR_H

#include "hetinv/context.h"
#include "hetinv/result.h"

/* The public function the calling thread is in (outermost), or NULL. Set
 * by HV_API_ENTER; read by hv_fail. Every public call reads and writes it,
 * so it uses the initial-exec TLS model: one %fs-relative access instead of
 * two __tls_get_addr calls (which doubled the cost of a trivial getter). It
 * takes 8 bytes of the static TLS surplus glibc reserves for dlopen. */
#if defined(__GNUC__) && defined(__ELF__)
#define HV_API_ENTRY_TLS __attribute__((visibility("hidden"), tls_model("initial-exec")))
#else
#define HV_API_ENTRY_TLS
#endif
extern _Thread_local const char *hv_api_entry HV_API_ENTRY_TLS;

/* Formats the message, prefixed with the name of the public function the
 * thread is in (or, outside any, @p func), records it (with code and
 * context) for the calling thread, calls the context's error callback, and
 * returns @p code, so that a failing path reads `return HV_FAIL(ctx, CODE,
 * "...", ...);`. */
#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
hetinv_result_t hv_fail(const hetinv_context_t *ctx, hetinv_result_t code, const char *func,
                        const char *fmt, ...);

/* Capacity of a failure's message, its terminating '\0' included. */
enum { HV_MESSAGE_CAPACITY = 1024 };

/* As hv_fail, for a failure that arose on rank @p origin of the context's
 * communicator and that a collective call carried here: the message is
 * this rank's copy, hetinv_context_last_error_rank() reports @p origin. */
#if defined(__GNUC__)
__attribute__((format(printf, 5, 6)))
#endif
hetinv_result_t hv_fail_from_rank(const hetinv_context_t *ctx, hetinv_result_t code, int32_t origin,
                                  const char *func, const char *fmt, ...);

/* The calling thread's last message if it records a failure of @p ctx with
 * @p code, else NULL: what a collective call carries from a failing rank to
 * the others. */
const char *hv_last_failure(const hetinv_context_t *ctx, hetinv_result_t code);

/* Failures name the public function the user called, whichever helper they
 * come from: helpers take no name parameter. */
#define HV_FAIL(ctx, code, ...) hv_fail((ctx), (code), __func__, __VA_ARGS__)

/* Shorthand for the ubiquitous NULL-argument check. */
#define HV_CHECK_NULL(ctx, ptr) \
  do { \
    if ((ptr) == NULL) return HV_FAIL((ctx), HETINV_ERROR_NULL_ARGUMENT, "'%s' is NULL", #ptr); \
  } while (0)

/* Makes @p name the thread's public entry unless one is already set (a public
 * function calling another reports the outer one, which the user called);
 * returns the entry to restore on leaving. */
static inline const char *hv_api_enter(const char *name) {
  const char *outer = hv_api_entry;
  if (outer == NULL) hv_api_entry = name;
  return outer;
}

static inline void hv_api_leave(const char *const *outer) { hv_api_entry = *outer; }

/* HV_API_ENTER(); is the first statement of every public (HETINV_API)
 * function: failures anywhere below it, in any helper, are prefixed with its
 * name. The cleanup attribute restores the outer entry on every return.
 * Without it (compilers other than GCC and Clang) the entry is simply
 * replaced and never restored: a failure is then attributed to the public
 * function entered last on the thread, which differs from the one called
 * only when a public function fails after calling another internally. */
#if defined(__GNUC__)
#define HV_API_ENTER() \
  __attribute__((cleanup(hv_api_leave), unused)) const char *const hv_api_outer_ = \
      hv_api_enter(__func__)
/* Carries an entry captured on the calling thread (hv_api_entry) to an
 * OpenMP worker for the rest of the enclosing block. */
#define HV_API_ADOPT(entry) \
  __attribute__((cleanup(hv_api_leave), unused)) const char *const hv_api_outer_ = \
      hv_api_adopt(entry)
#else
#define HV_API_ENTER() (void)(hv_api_entry = __func__)
#define HV_API_ADOPT(entry) (void)(hv_api_entry = (entry))
#endif

/* User code the library calls (the error and progress callbacks) is outside
 * the library: a public function it calls reports its own name. Brackets
 * the call: `const char *e = hv_api_suspend(); fn(...); hv_api_resume(e);` */
static inline const char *hv_api_suspend(void) {
  const char *entry = hv_api_entry;
  hv_api_entry = NULL;
  return entry;
}

static inline void hv_api_resume(const char *entry) { hv_api_entry = entry; }

static inline const char *hv_api_adopt(const char *entry) {
  const char *outer = hv_api_entry;
  hv_api_entry = entry;
  return outer;
}

#endif
