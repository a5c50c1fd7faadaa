/* Allocation through the context's hooks, with overflow-checked sizes. */
#ifndef HV_ALLOC_H
#define HV_ALLOC_H

#include <stdbool.h>
#include <stddef.h>

#include "hetinv/context.h"

/* NULL for size 0 or on failure (callers report HETINV_ERROR_OUT_OF_MEMORY). */
void *hv_alloc(const hetinv_context_t *ctx, size_t size);
/* Zeroed array of n elements; NULL on failure or if n·size overflows. */
void *hv_calloc(const hetinv_context_t *ctx, size_t n, size_t size);
/* hv_calloc for one thread's private array, followed by HV_CACHE_GAP
 * unused bytes, so that its last cache line holds nothing another thread
 * writes: the heap places blocks side by side. Freed by hv_free. */
void *hv_calloc_apart(const hetinv_context_t *ctx, size_t n, size_t size);
/* NULL is a no-op. */
void hv_free(const hetinv_context_t *ctx, void *ptr);
/* Copy of a NUL-terminated string; NULL on failure. */
char *hv_strdup(const hetinv_context_t *ctx, const char *s);

/* *out = a·b; false (and *out untouched) if it overflows. */
static inline bool hv_mul_size(size_t a, size_t b, size_t *out) {
  if (b != 0 && a > (size_t)-1 / b) return false;
  *out = a * b;
  return true;
}

#endif
