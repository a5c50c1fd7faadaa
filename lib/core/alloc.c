#include "core/alloc.h"

#include <stdlib.h>
#include <string.h>

#include "core/compiler.h"
#include "core/context_internal.h"

void *hv_alloc(const hetinv_context_t *ctx, size_t size) {
  if (size == 0) return NULL;
  if (ctx != NULL && ctx->alloc_fn != NULL) return ctx->alloc_fn(ctx->alloc_user_data, size);
  return malloc(size);
}

void *hv_calloc(const hetinv_context_t *ctx, size_t n, size_t size) {
  size_t total;
  if (!hv_mul_size(n, size, &total)) return NULL;
  void *p = hv_alloc(ctx, total);
  if (p != NULL) memset(p, 0, total);
  return p;
}

void *hv_calloc_apart(const hetinv_context_t *ctx, size_t n, size_t size) {
  size_t total;
  if (!hv_mul_size(n, size, &total) || total > (size_t)-1 - HV_CACHE_GAP) return NULL;
  return hv_calloc(ctx, 1, total + HV_CACHE_GAP);
}

void hv_free(const hetinv_context_t *ctx, void *ptr) {
  if (ptr == NULL) return;
  if (ctx != NULL && ctx->free_fn != NULL) {
    ctx->free_fn(ctx->alloc_user_data, ptr);
  } else {
    free(ptr);
  }
}

char *hv_strdup(const hetinv_context_t *ctx, const char *s) {
  size_t n = strlen(s) + 1;
  char *copy = hv_alloc(ctx, n);
  if (copy != NULL) memcpy(copy, s, n);
  return copy;
}
